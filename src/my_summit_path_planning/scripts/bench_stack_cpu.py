#!/usr/bin/python3
"""Benchmark of the navigation stack's CPU: map_server + amcl + move_base on a fixed,
seeded 10-goal run on the built-in world.

Each run: `move_base.launch sim:=true` (the simulator on the built-in world at --speed,
map_server with my_map, amcl with config/amcl_params.yaml, move_base with the course's
six YAML files: NavFn + DWA) on a private ROS master. Once amcl has published its first
pose and move_base's action server is up, the --goals goals of seed --seed are sent one
after the other through the move_base action, each when the previous one has ended
(GOAL_TIMEOUT simulated seconds at most). The goals are free cells of the world at least
GOAL_CLEARANCE m from a wall, reachable from the spawn pose through cells at least
PASS_CLEARANCE m from a wall, MIN_STEP..MAX_STEP m from the previous goal, with a random
heading: the same goals in every run. The window measured is from the first goal sent to
the last goal's end, "while navigating":
  cpu_per_sim_s   per node (map_server, amcl, move_base; the simulator beside them):
                  utime + stime of /proc/<pid>/stat over the window / simulated time
                  (/clock); sum: map_server + amcl + move_base
  peak_rss_mb     per node, VmHWM at the window's end [MB]
  minor_faults_per_sim_s  per node: pages the kernel mapped and zeroed for it (memory
                  returned to the system and taken again costs CPU here)
  reached         goals move_base reported succeeded; collisions (the simulator's
                  /collisions count); the final position error by ground truth: so a
                  cheaper node that drives worse shows
  threads         move_base's CPU seconds per thread in the window (costmaps, planner,
                  control loop, receive threads by topic with --profile)
With --profile DIR, move_base runs under summit_nav_common.testing.profile_node
--all-threads (cProfile in every thread, CPU clock); DIR/move_base_run<i>.pstats holds the profile, and the share
of the profiled CPU of each stage (PROFILE_STAGES: costmap layers, laser tf and scan
conversion, costmap publishing, NavFn, DWA's distance fields / rollouts / scoring, the
control loop's tf and messages, receiving messages) goes to the JSON as profile_shares.
The profiler slows the node: a profiled run's CPU figures are not the benchmark's.

Issue 24's figure: map_server + amcl + move_base while navigating <= 0.6 CPU s per
simulated s; the real C++ nodes on the same kind of scenario (the issue's reference,
not measured here): amcl 0.094, move_base 0.41, sum 0.50.

--global-planner / --local-planner run move_base with another plugin (e.g. global_planner/
GlobalPlanner, base_local_planner/TrajectoryPlannerROS): the course's config files with
move_base_params.yaml's base_global_planner / base_local_planner changed (config_dir:=).

Usage: bench_stack_cpu.py [--runs 3] [--goals 10] [--seed 0] [--speed 1] [--json PATH]
                          [--profile DIR] [--global-planner NAME] [--local-planner NAME]
"""
import argparse
import json
import math
import os
import statistics
import sys
import time

import numpy as np

from summit_nav_common.testing import profile_node, roslaunch_session

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.abspath(os.path.join(HERE, "..", "..", ".."))

TARGET_SUM_CPU_PER_SIM_S = 0.6           # issue 24: map_server + amcl + move_base while navigating
REAL_CPU_PER_SIM_S = {"amcl": 0.094, "move_base": 0.41, "sum": 0.50}   # issue 24's C++ reference
NODES = ("map_server", "amcl", "move_base")   # the stack; the simulator is reported beside it
SIM_NODE = "summit_xl_sim"
WORLD = os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml")
MAP_IN_WORLD = (2.0, 7.0)   # the map frame's origin in the world (the spawn pose; yaw 0)
GOAL_CLEARANCE = 0.6        # [m] goal to the nearest wall, at least
PASS_CLEARANCE = 0.4        # [m] cells the robot can pass through (half width 0.31 + padding)
MIN_STEP, MAX_STEP = 3.0, 14.0   # [m] straight line from the previous goal (the first: the spawn)
GOAL_TIMEOUT = 120.0        # [s simulated] per goal
START_TIMEOUT = 180.0       # [s wall] the stack up: amcl's first pose, move_base's action server
CONFIG_DIR = os.path.join(WS, "src", "my_summit_path_planning", "config")


def config_dir(tmp, global_planner=None, local_planner=None):
    """The course's config folder, or (a planner named) a copy in tmp whose
    move_base_params.yaml names that planner."""
    if not global_planner and not local_planner:
        return CONFIG_DIR
    import re
    import shutil
    import tempfile
    out = os.path.join(tempfile.mkdtemp(prefix="config_", dir=tmp), "config")
    shutil.copytree(CONFIG_DIR, out)
    path = os.path.join(out, "move_base_params.yaml")
    text = open(path).read()
    for key, name in (("base_global_planner", global_planner), ("base_local_planner", local_planner)):
        if name:
            text, n = re.subn(rf"^{key}:.*$", f"{key}: {name}", text, flags=re.M)
            if n != 1:
                raise RuntimeError(f"{path}: no single line '{key}:' to replace")
    with open(path, "w") as f:
        f.write(text)
    return out


def draw_goals(n, seed):
    """n seeded goals (x, y, yaw) in the map frame (see the module docstring)."""
    from scipy import ndimage
    from summit_xl_sim.world import World
    world = World.from_yaml(WORLD)
    clear = world.dist * world.resolution
    labels, _ = ndimage.label(clear >= PASS_CLEARANCE)
    sx, sy = world.to_grid(*MAP_IN_WORLD)
    region = labels[int(sy), int(sx)]
    if region == 0:
        raise RuntimeError(f"the spawn pose {MAP_IN_WORLD} is not in free space of {WORLD}")
    ys, xs = np.nonzero((labels == region) & (clear >= GOAL_CLEARANCE))
    rng = np.random.default_rng(seed)
    goals, prev = [], (0.0, 0.0)
    while len(goals) < n:
        k = rng.integers(len(xs))
        wx, wy = world.grid.cell_to_world(xs[k], ys[k])
        x, y = wx - MAP_IN_WORLD[0], wy - MAP_IN_WORLD[1]
        if MIN_STEP <= math.hypot(x - prev[0], y - prev[1]) <= MAX_STEP:
            goals.append((round(float(x), 3), round(float(y), 3), round(float(rng.uniform(-math.pi, math.pi)), 3)))
            prev = (x, y)
    return goals


def run_once(index, args, tmp):
    import rospy
    from summit_nav_common.testing.roslaunch_session import (RoslaunchSession, cpu_seconds, find_node_pid,
                                                             minor_faults, peak_rss_mb, thread_cpu, wait_for,
                                                             wait_for_sim_time_param)
    prefix = ""
    out_prefix = None
    if args.profile:
        out_prefix = os.path.join(os.path.abspath(args.profile), f"move_base_run{index}")
        prefix = profile_node.launch_prefix(out_prefix, all_threads=True)
    goals = draw_goals(args.goals, args.seed)
    log = os.path.join(tmp, f"bench_stack_cpu_run{index}.log")
    launch = ["my_summit_path_planning", "move_base.launch", "sim:=true", f"speed:={args.speed}",
              f"seed:={args.seed}", f"launch_prefix:={prefix}",
              f"config_dir:={config_dir(tmp, args.global_planner, args.local_planner)}"]
    with RoslaunchSession(launch, log=log) as session:
        wait_for_sim_time_param(session)
        rospy.init_node("bench_stack_cpu", anonymous=True, disable_signals=True)
        from geometry_msgs.msg import PoseWithCovarianceStamped
        from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits
        first_pose = waits.Latest("/amcl_pose", PoseWithCovarianceStamped)
        truth = gt.Truth(gt.spawn_in_world())
        wait_for(lambda: first_pose.msg is not None, START_TIMEOUT, "amcl's first pose", session)
        client = mb.client()
        truth.wait()
        waits.sleep_sim(2.0)  # amcl settles on its first scans
        pids = {name: find_node_pid(session.proc.pid, name) for name in NODES + (SIM_NODE,)}
        missing = [n for n, p in pids.items() if p is None]
        if missing:
            raise RuntimeError(f"process of {missing} not found; see {log}")
        load0 = os.getloadavg()
        sim0 = rospy.Time.now().to_sec()
        cpu0 = {n: cpu_seconds(p) for n, p in pids.items()}
        flt0 = {n: minor_faults(p) for n, p in pids.items()}
        thr0 = thread_cpu(pids["move_base"])
        wall0 = time.monotonic()
        results = []
        for i, goal in enumerate(goals):
            t0 = rospy.Time.now().to_sec()
            client.send_goal(mb.make_goal(*goal))
            try:
                state, text = mb.wait_result(client, GOAL_TIMEOUT, timeout_wall=GOAL_TIMEOUT / args.speed * 4 + 60)
            except AssertionError as e:   # did not end in time: cancel it, go on with the next
                client.cancel_goal()
                waits.sleep_sim(1.0)
                state, text = "TIMEOUT", str(e)
            pose = truth.pose
            err = math.hypot(pose[0] - goal[0], pose[1] - goal[1])
            results.append({"goal": goal, "state": state, "text": text, "sim_s": round(rospy.Time.now().to_sec() - t0, 1),
                            "final_error_m": round(err, 3)})
            print(f"goal {i + 1}/{len(goals)} ({goal[0]:.2f}, {goal[1]:.2f}): {state} in "
                  f"{results[-1]['sim_s']} s sim, {err:.3f} m from it by ground truth; collisions so far "
                  f"{truth.collisions}", flush=True)
        sim1 = rospy.Time.now().to_sec()
        cpu1 = {n: cpu_seconds(p) for n, p in pids.items()}
        flt1 = {n: minor_faults(p) for n, p in pids.items()}
        thr1 = thread_cpu(pids["move_base"])
        wall1 = time.monotonic()
        rss = {n: peak_rss_mb(p) for n, p in pids.items()}
        load1 = os.getloadavg()
        collisions = truth.collisions
    sim_s = sim1 - sim0
    cpu = {n: (cpu1[n] - cpu0[n]) / sim_s for n in pids}
    cpu["sum"] = sum(cpu[n] for n in NODES)
    faults = {n: round((flt1[n] - flt0[n]) / sim_s) for n in pids}
    names = {}
    if out_prefix and os.path.exists(out_prefix + ".threads.json"):
        with open(out_prefix + ".threads.json") as f:
            names = {int(k): v for k, v in json.load(f)["threads"].items()}
    threads = {}
    for tid, c in thr1.items():
        key = names.get(tid, "main" if tid == pids["move_base"] else f"tid {tid}")
        threads[key] = round(threads.get(key, 0.0) + c - thr0.get(tid, 0.0), 3)
    reached = [r for r in results if r["state"] == "SUCCEEDED"]
    return dict(run=index, sim_s=sim_s, wall_s=wall1 - wall0, cpu_per_sim_s=cpu, peak_rss_mb=rss,
                minor_faults_per_sim_s=faults,
                goals=len(goals), reached=len(reached), collisions=int(collisions),
                final_error_m_median=statistics.median(r["final_error_m"] for r in reached) if reached else None,
                goal_results=results, threads={k: v for k, v in sorted(threads.items(), key=lambda kv: -kv[1])
                                              if v > 0.0},
                load_average=[round(x, 2) for x in load0 + load1], profile=out_prefix, log=log)


# Where move_base's time goes: stage -> functions whose cumulative CPU it is (file suffix,
# function name); a stage's figure is its cumulative CPU minus the stages listed after it
# that run inside it (CONTAINS).
PROFILE_STAGES = (
    ("costmaps: obstacle layer (marking, raytracing)",
     [("layers.py", "update_bounds"), ("layers.py", "add_observation")]),
    ("costmaps: inflation layer", [("layers.py", "update_costs")]),
    ("costmaps: laser tf and scan conversion", [("nodes/move_base", "_add_observations")]),
    ("costmaps: rest of the update (master reset, static layer, rolling)", [("nodes/move_base", "update")]),
    ("costmaps: publishing (costmap, footprint)", [("nodes/move_base", "publish")]),
    ("global planner (NavFn) and costmap snapshot", [("nodes/move_base", "_make_plan"),
                                                     ("nodes/move_base", "snapshot")]),
    ("DWA: obstacle distance field", [("dwa.py", "obstacle_distance")]),
    ("DWA: path / goal distance maps", [("dwa.py", "path_distance_maps")]),
    ("DWA: rollouts and footprint checks", [("dwa.py", "rollouts")]),
    ("DWA: scoring and choice", [("dwa.py", "scores"), ("dwa.py", "choose"), ("dwa.py", "obstacle_costs"),
                                 ("dwa.py", "goal_approach")]),
    ("DWA / move_base core: the rest of a control cycle", [("move_base_core.py", "cycle")]),
    ("control loop: robot pose tf, feedback, cmd_vel, local plan", [("nodes/move_base", "_cycle")]),
    ("receiving messages (tf, scans, odom, clock): reading, deserializing, callbacks",
     [("tcpros_base.py", "receive_once")]),
)
CONTAINS = {   # stage index -> indices of the stages that run inside it
    2: [],
    3: [0, 1, 2],
    10: [6, 7, 8, 9],
    11: [6, 7, 8, 9, 10],
}


def profile_summary(path):
    """{stage: share of the profiled CPU} of a profile (PROFILE_STAGES)."""
    return profile_node.stage_shares(path, PROFILE_STAGES, CONTAINS,
                                     other="other (rospy, actionlib, timers, thread bookkeeping)")


def child(args):
    return profile_node.child_run(run_once, args, "bench_stack_cpu_", profile_summary)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--goals", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0, help="seed of the goals and of the simulator's noise")
    ap.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall second")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--profile", metavar="DIR", help="run move_base under summit_nav_common.testing.profile_node, profiles in DIR")
    ap.add_argument("--print-goals", action="store_true", help="print the goals and exit")
    ap.add_argument("--global-planner", help="move_base's base_global_planner (default: the course's navfn/NavfnROS)")
    ap.add_argument("--local-planner", help="move_base's base_local_planner (default: the course's DWAPlannerROS)")
    ap.add_argument("--run-index", type=int, help=argparse.SUPPRESS)   # one run, in a child process
    args = ap.parse_args()
    roslaunch_session.exit_on_sigterm()   # `kill PID` stops the runs' graphs too
    if args.print_goals:
        for g in draw_goals(args.goals, args.seed):
            print(g)
        return 0
    if args.profile:
        os.makedirs(args.profile, exist_ok=True)
    if args.run_index is not None:
        return child(args)
    runs = []
    for i in range(args.runs):
        cmd = [sys.executable, os.path.abspath(__file__), "--run-index", str(i), "--goals", str(args.goals),
               "--seed", str(args.seed), "--speed", str(args.speed)]
        cmd += ["--profile", args.profile] if args.profile else []
        cmd += ["--global-planner", args.global_planner] if args.global_planner else []
        cmd += ["--local-planner", args.local_planner] if args.local_planner else []
        r = profile_node.run_child(cmd, i)
        runs.append(r)
        c = r["cpu_per_sim_s"]
        print(f"run {i}: CPU s per simulated s: " + ", ".join(f"{n} {c[n]:.3f}" for n in NODES)
              + f", sum {c['sum']:.3f} (simulator {c[SIM_NODE]:.3f}) over {r['sim_s']:.1f} s simulated "
              f"({r['wall_s']:.1f} s wall); peak RSS " + ", ".join(f"{n} {r['peak_rss_mb'][n]:.0f} MB" for n in NODES)
              + "; minor page faults per simulated s " + ", ".join(f"{n} {r['minor_faults_per_sim_s'][n]}" for n in NODES)
              + f"; reached {r['reached']} of {r['goals']}, collisions {r['collisions']}; load {r['load_average']}",
              flush=True)
        print("   move_base threads (CPU s): " + ", ".join(f"{k} {v:.2f}" for k, v in r["threads"].items()), flush=True)
        if "profile_shares" in r:
            print("   profile (share of move_base's profiled CPU): " +
                  ", ".join(f"{k} {v:.0%}" for k, v in r["profile_shares"].items()), flush=True)
    keys = NODES + ("sum", SIM_NODE)
    median = {"cpu_per_sim_s": {k: statistics.median(r["cpu_per_sim_s"][k] for r in runs) for k in keys},
              "peak_rss_mb": {k: statistics.median(r["peak_rss_mb"][k] for r in runs) for k in NODES + (SIM_NODE,)},
              "minor_faults_per_sim_s": {k: statistics.median(r["minor_faults_per_sim_s"][k] for r in runs)
                                         for k in NODES + (SIM_NODE,)},
              "reached": statistics.median(r["reached"] for r in runs),
              "sim_s": statistics.median(r["sim_s"] for r in runs)}
    result = dict(runs=runs, median=median, goals=args.goals, seed=args.seed, speed=args.speed,
                  reached_min=min(r["reached"] for r in runs), collisions=sum(r["collisions"] for r in runs),
                  target_sum_cpu_per_sim_s=TARGET_SUM_CPU_PER_SIM_S, real_cpu_per_sim_s=REAL_CPU_PER_SIM_S,
                  profiled=bool(args.profile), global_planner=args.global_planner,
                  local_planner=args.local_planner)
    if args.profile and "profile_shares" in runs[0]:
        result["profile_shares"] = runs[0]["profile_shares"]
        result["threads"] = runs[0]["threads"]
    m = median["cpu_per_sim_s"]
    print(f"median of {len(runs)}: CPU s per simulated s " + ", ".join(f"{n} {m[n]:.3f}" for n in NODES)
          + f", sum {m['sum']:.3f} (target <= {TARGET_SUM_CPU_PER_SIM_S}; the issue's C++ reference "
          f"{REAL_CPU_PER_SIM_S['sum']}); reached (worst run) {result['reached_min']} of {args.goals}, collisions "
          f"(all runs) {result['collisions']}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
