#!/usr/bin/python3
"""`make bench`: performance benchmarks, printed as tables, written as JSON and as a page.

Each section run is recorded with its rows (figure, measured, target, met), the commit,
date, machine and the load average during it (tools/bench_report.py); the record replaces
that section in the committed store docs/bench.json, from which docs/benchmarks.md and
the README's table are rendered (`--render`, `make bench-page`: no run). This run's raw
results also go to output/bench.json.

Benchmarks measure; they do not pass or fail (the tests stay free of wall-clock
thresholds). Each figure is the median of several runs; peak resident memory is given
beside each time. Sections:
  laser       simulated scans per second (1081 beams) on the built-in world and on
              willow-full, one core, the simulator's ray casting alone
  sim_rtf     the simulator's real-time factor with one robot, running as fast as it can
              with every topic subscribed (/clock, /tf, /odom, ground truth, 40 Hz scans);
              one profiled run for where its time goes
  slam_carmen the SLAM core offline on the CARMEN Intel and ACES logs
  slam_bag    slam_gmapping (ROS node, the real node's evaluation parameters) on the
              CARMEN Intel and ACES logs played from a rosbag (rosbag play --clock -r
              BAG_RATE), seeds 1-5: online aligned ATE, CPU per filter update, peak RSS
  slam_bag_peer (only with --only slam_bag_peer --gmapping EXE [--gmapping-setup SETUP]) the
              same on another slam_gmapping executable, e.g. the real gmapping as the oracle
  slam_bag_karto  slam_karto (ROS node, graph SLAM, its defaults with the same frames and
              resolution) on slam_bag's bags, seeds and scoring: online and final-trajectory
              ATE, CPU per scan added to the graph, peak RSS
  slam_bag_karto_peer (only with --only slam_bag_karto_peer --karto EXE [--karto-setup SETUP])
              the same on another slam_karto executable, e.g. the real slam_karto as the oracle
  slam_replay_peer (only with --only slam_replay_peer --gmapping-replay EXE [--gmapping-replay-setup
              SETUP]) the real gmapping's filter seeded (its slam_gmapping_replay) and ours on
              slam_bag's bags, seeds 1-10 each (bench_slam_replay.py): the spread over seeds
  slam_sim    slam_gmapping (ROS node, course parameters, 30 particles) over the tour of
              the built-in world: ATE vs ground truth, map precision / recall, CPU per
              simulated second, peak RSS; one profiled tour for where the node's time goes
  amcl        the amcl core: update cost (5000 particles, 61 beams), tracking on the tour,
              global localization from 20 seeded poses, kidnapping (10 runs); the live
              node on the tour: CPU per simulated second, and a profile of where it goes
  ekf         ekf_localization_node on the tour with the skid-steer odometry and the IMU, seeds 1-5
              (bench_ekf.py: each seed's tour recorded once into a bag, played at 1x): heading error
              after the tour and ATE without alignment, raw odometry and fused; CPU per simulated
              second, peak RSS
  ekf_peer    (only with --only ekf_peer --ekf-node EXE [--ekf-node-setup SETUP]) the same bags and
              YAML played to another ekf_localization_node, e.g. the real robot_localization's
  ekf_downstream  amcl and slam_gmapping on the tour with the skid-steer odometry, on the raw wheel
              odometry and on the EKF's, seeds 1-5, each live (bench_ekf_downstream.py): amcl's
              position and yaw error against the truth (median, max over the tour), slam_gmapping's
              ATE and map precision / recall
  planning    the path-planning core (no ROS): NavFn and GlobalPlanner (A*, Dijkstra) plan
              time on willow-full-0.05 and their paths against the exact grid geodesic;
              one DWA control cycle; closed loop (global + local costmaps, simulator) of
              every global planner (NavFn, GlobalPlanner A*, Dijkstra) with every local
              planner (DWA, TrajectoryPlanner with dwa false and true) over the same 50
              seeded goal pairs on the built-in world and 20 on willow-full-0.05: share
              reached, collisions, median of time to goal / (grid geodesic / max_vel_x)
              and / (planned path length / max_vel_x)
  planning_peer (only with --only planning_peer --move-base EXE [--move-base-setup SETUP]) a
              move_base executable, e.g. the real one as the oracle, live on planning's 20
              willow-full-0.05 pairs (navfn with DWA, TrajectoryPlanner dwa false and true;
              bench_move_base_live.py): reached, collisions
  stack_cpu   map_server + amcl + move_base (move_base.launch sim:=true, the course's config) on a
              fixed, seeded 10-goal run on the built-in world at 1x real time
              (bench_stack_cpu.py): CPU per simulated second and peak RSS per node, goals
              reached, collisions; one profiled run of move_base for where its time goes
  explore     frontier exploration (explore.launch, real time) of the built-in world from 5
              seeded start poses and of willow-full from one: explored share of the reachable free area,
              collisions, simulated time, map precision / recall
  explore_karto the same with slam:=karto (slam_karto, loop closure) on willow-full from one
              start (EXPLORE_KARTO_RUNS)
  explore_karto_peer (only with --only explore_karto_peer --karto EXE [--karto-setup SETUP])
              explore_karto with that slam_karto executable (the real one) in ours' place,
              the same YAML and start
  patrol      the patrol: 10 rounds over table, room, turtle with a box dropped on the route
              twice: spots reached / skipped, collisions, the boxes kept clear of
  race_track  the race-track tutorial (issue 40): 10 laps at 1x with a battery small enough for
              at least two charging stops and a box on the narrow section (waypoints reached /
              skipped, collisions, each low battery docked and resumed, nav_health's
              localization error, planning time, control rate, CPU per node); 2 laps with the
              adaptive parameters off and on at 2x (lap time, least clearance to a wall)
  multi_robot the multi-robot lesson (both robots' goals, amcl and fake_localization) and
              the number of robots (amcl + move_base each) run at >= 1x real time
  memory      peak RSS per node on the benchmark's own runs (map_server, amcl, move_base: stack_cpu's
              first MEMORY_GOALS goals; slam_gmapping: slam_bag's Intel bag, seed 1) beside the real
              C++ node's (--real-stack-json: real_stack_rss.py's JSON of the real stack on the same
              goals; the stored slam_bag_peer record), and the stack's startup (launch to move_base
              accepting a goal, median of STARTUP_RUNS)
  e2e         (only with --only e2e) the end-to-end rostest once per seed 1..10 at 4x real time,
              with the scans each node skipped because it fell behind

    make bench                      all sections
    make bench BENCH_ARGS="--only laser --runs 3"
    make bench BENCH_ARGS="--only slam_carmen --carmen-logs intel"
    make bench BENCH_ARGS="--only slam_bag --carmen-logs intel --bag-rate 1"
    make bench BENCH_ARGS="--only explore --explore-worlds builtin"
    make bench BENCH_ARGS="--only memory --real-stack-json REAL_STACK.json"
    make bench-page                 re-render the page from docs/bench.json
"""
import argparse
import json
import os
import re
import resource
import shlex
import statistics
import subprocess
import sys
import threading
import time

import numpy as np

import bench_report  # a sibling (the page's records and rendering; --render needs nothing more)

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(WS, "output")
DATA = os.path.join(WS, "data")  # real maps and logs (data/README.md)
WORLDS = {
    "built-in course building": os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml"),
    "willow-full (0.1 m)": os.path.join(WS, "src", "my_summit_navigation", "maps", "willow-full.yaml"),
    "willow-full-0.05": os.path.join(DATA, "maps", "willow-full-0.05.yaml"),
}


def peak_rss_mb():
    """Peak resident memory of this process so far [MB]."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def bench_laser(runs, scans_per_run=500):
    """Scans per second of World.cast with 1081 beams from random free poses."""
    from summit_xl_sim.sim import LaserParams
    from summit_xl_sim.world import World

    rows = []
    angles = LaserParams().angles()
    for name, path in WORLDS.items():
        if not os.path.exists(path):
            raise FileNotFoundError(f"laser benchmark: map {path} is missing (a partial checkout?)")
        world = World.from_yaml(path)
        rng = np.random.default_rng(0)
        ys, xs = np.nonzero((world.dist * world.resolution > 0.4) & (world.grid.data == 0))
        sel = rng.choice(len(xs), scans_per_run)
        poses = [world.grid.cell_to_world(xs[k], ys[k]) + (rng.uniform(-np.pi, np.pi),) for k in sel]
        world.cast(poses[0][0], poses[0][1], angles, 30.0)  # compile / warm up
        rates = []
        for _ in range(runs):
            t0 = time.process_time()
            for x, y, yaw in poses:
                world.cast(x, y, angles + yaw, 30.0)
            rates.append(scans_per_run / (time.process_time() - t0))
        rows.append({"world": name, "cells": f"{world.grid.width} x {world.grid.height}",
                     "scans_per_s": statistics.median(rates), "runs": [round(r) for r in rates],
                     "peak_rss_mb": peak_rss_mb()})
    return rows


def bench_sim_rtf_once(seconds=20.0, profile=None):
    """Real-time factor of the simulator node at speed 0 (as fast as it can), one run.

    rospy binds a process to one master, so each run is a child process (see
    bench_sim_rtf_runs) with its own launch. With profile (a path prefix) the simulator
    runs under summit_nav_common.testing.profile_node and its stage shares are returned
    instead.
    """
    import psutil
    import rospy
    from summit_nav_common.testing import profile_node
    from summit_nav_common.testing.roslaunch_session import RoslaunchSession, wait_for
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from rospy.numpy_msg import numpy_msg
    from sensor_msgs.msg import LaserScan
    from tf2_msgs.msg import TFMessage

    log = os.path.join(OUT, "bench_sim_rtf.log")
    launch = ["summit_xl_sim", "sim.launch", "speed:=0"]
    if profile:
        launch.append("launch_prefix:=" + profile_node.launch_prefix(profile, all_threads=True))
    with RoslaunchSession(launch, log=log) as session:
        rospy.init_node("bench", anonymous=True, disable_signals=True)
        counts = {"scan": 0, "odom": 0, "truth": 0, "tf": 0, "clock": 0}
        latest = {"t": 0.0}
        lock = threading.Lock()

        def counter(key):
            def cb(msg):
                with lock:
                    counts[key] += 1
                    if key == "clock":
                        latest["t"] = msg.clock.to_sec()
            return cb

        rospy.Subscriber("/hokuyo_base/scan", numpy_msg(LaserScan), counter("scan"), queue_size=100)
        rospy.Subscriber("/odom", Odometry, counter("odom"), queue_size=100)
        rospy.Subscriber("/base_pose_ground_truth", Odometry, counter("truth"), queue_size=100)
        rospy.Subscriber("/tf", TFMessage, counter("tf"), queue_size=100)
        rospy.Subscriber("/clock", Clock, counter("clock"), queue_size=100)
        wait_for(lambda: counts["scan"] > 0, 60, "the first scan", session)
        sim = next(p for p in psutil.Process(session.proc.pid).children(recursive=True)
                   if "summit_xl_sim/summit_xl_sim" in " ".join(p.cmdline()))
        cpu0 = sum(sim.cpu_times()[:2])
        with lock:
            t0, c0 = latest["t"], dict(counts)
        w0 = time.monotonic()
        time.sleep(seconds)
        with lock:
            t1, c1 = latest["t"], dict(counts)
        w1 = time.monotonic()
        cpu1 = sum(sim.cpu_times()[:2])
        rss = sim.memory_info().rss / 1e6
    sim_s = max(t1 - t0, 1e-9)
    if profile:
        profile_node.print_profile(profile + ".pstats", 25)
        return {"profile_shares": profile_node.stage_shares(profile + ".pstats", SIM_PROFILE_STAGES,
                                                            SIM_PROFILE_CONTAINS)}
    return {"rtf": sim_s / (w1 - w0), "sim_cpu_s_per_sim_s": (cpu1 - cpu0) / sim_s,
            "scan_hz_sim": (c1["scan"] - c0["scan"]) / sim_s, "odom_hz_sim": (c1["odom"] - c0["odom"]) / sim_s,
            "clock_hz_sim": (c1["clock"] - c0["clock"]) / sim_s, "sim_rss_mb": rss}


# Where the simulator's time goes: stage -> functions whose cumulative CPU it is
SIM_PROFILE_STAGES = (
    ("laser: ray casting", [("world.py", "cast"), ("world.py", "cast_hits")]),
    ("laser: range model (noise, mixed pixels, no returns)", [("laser_model.py", "measure")]),
    ("laser: the rest of a scan (pose, other robots)", [("sim.py", "scan")]),
    ("physics step (motion, odometry drift, collisions)", [("sim.py", "step")]),
    ("publishing (clock, odom, tf, scans): serializing and sending", [("rospy/topics.py", "publish")]),
    ("receiving messages (its own /clock, as rospy subscribes it under use_sim_time; cmd_vel)",
     [("tcpros_base.py", "receive_once")]),
    ("the rest of the loop (building odom and tf messages, pacing)", [("nodes/summit_xl_sim", "run")]),
    ("start-up (imports, loading the world)", [("nodes/summit_xl_sim", "<module>")]),
)
# a scan contains the cast and the range model; the loop its scans, steps and publishing;
# the node's module everything its main thread did
SIM_PROFILE_CONTAINS = {2: [0, 1], 6: [2, 3, 4], 7: [6]}


def _sim_rtf_child(extra=()):
    r = subprocess.run([sys.executable, __file__, "--only", "sim_rtf_child"] + list(extra), stdout=subprocess.PIPE,
                       stderr=subprocess.DEVNULL, text=True, timeout=300)
    line = [l for l in r.stdout.splitlines() if l.startswith("{")]
    if r.returncode != 0 or not line:
        raise RuntimeError(f"simulator benchmark child failed:\n{r.stdout[-2000:]}")
    print(r.stdout[:r.stdout.rfind(line[-1])], end="")
    return json.loads(line[-1])


def bench_sim_rtf_runs(runs):
    """Runs bench_sim_rtf in `runs` child processes (one ROS master each); medians; then
    one profiled run for where the time goes."""
    rows = [_sim_rtf_child() for _ in range(runs)]
    med = {k: statistics.median(r[k] for r in rows) for k in rows[0]}
    med["runs_rtf"] = [round(r["rtf"], 1) for r in rows]
    med["profile_shares"] = _sim_rtf_child(["--profile", os.path.join(OUT, "sim_profile")])["profile_shares"]
    return med


def _run_script(package, script, args, json_name, check=True):
    """src/<package>/scripts/<script> run with args and --json OUT/json_name; its JSON result.
    check=False: a script that exits 1 when its runs miss their targets still gives its result."""
    path = os.path.join(OUT, json_name)
    if os.path.exists(path):
        os.remove(path)   # never a previous run's result
    subprocess.run([sys.executable, os.path.join(WS, "src", package, "scripts", script)] + args + ["--json", path],
                   check=check)
    with open(path) as f:
        return json.load(f)


def bench_slam_carmen(logs=None):
    """bench_slam_carmen.py on `logs` (names, default all of its logs)."""
    return _run_script("my_summit_mapping", "bench_slam_carmen.py",
                       ["--out", OUT] + (["--logs"] + logs if logs else []), "bench_slam_carmen.json")


BAG_RATE = 4.0          # rosbag play rate of slam_bag: on 2 cores at load ~9 the node kept up
                        # (Intel: every update done, about 0.25 core) and its online ATE equals
                        # the offline core's on the same seed and scans
BAG_SEEDS = (1, 2, 3, 4, 5)   # median and worst of 5 (the real gmapping's reference figures: 3 runs)
CARMEN_LOGS = {"intel": "intel-corrected.log.gz", "aces": "aces-corrected.log.gz"}


def _node_args(node, setup, setup_flag="--node-setup"):
    """The arguments that hand a benchmark script another executable (node) in ours' place
    and the bash file its environment needs: [] when node is None."""
    return (["--node", node] + ([setup_flag, setup] if setup else [])) if node else []


def bench_slam_bag(logs=None, rate=BAG_RATE, seeds=BAG_SEEDS, node=None, node_setup=None, slam="gmapping"):
    """bench_slam_bag.py on each of `logs` (names, default intel and aces); slam: the node
    under test (gmapping or karto); node: another executable with its interface run instead
    of ours (node_setup: the bash file its environment needs), for the *_peer sections."""
    res = {"rate": rate, "logs": {}, "node": node, "slam": slam}
    tag = ("_karto" if slam == "karto" else "") + ("_peer" if node else "")
    extra = _node_args(node, node_setup) + ["--slam", slam]
    for name in logs or list(CARMEN_LOGS):
        res["logs"][name] = _run_script(
            "my_summit_mapping", "bench_slam_bag.py",
            [os.path.join(DATA, "carmen", CARMEN_LOGS[name]), "--rate", str(rate), "--seeds"]
            + [str(s) for s in seeds] + ["--out", os.path.join(OUT, f"slam_bag{tag}_{name}")] + extra,
            f"bench_slam_bag{tag}_{name}.json")
    return res


REPLAY_SEEDS = tuple(range(1, 11))   # one live run per seed cannot show a spread of 0.15-3 m on ACES


def bench_slam_replay(exe, setup, logs=None, seeds=REPLAY_SEEDS):
    """bench_slam_replay.py on each of `logs` (names, default intel and aces): the real
    gmapping's seeded player `exe` (setup: the bash file its environment needs) and ours."""
    res = {"logs": {}, "replay": exe}
    for name in logs or list(CARMEN_LOGS):
        res["logs"][name] = _run_script(
            "my_summit_mapping", "bench_slam_replay.py",
            [os.path.join(DATA, "carmen", CARMEN_LOGS[name]), "--replay", exe, "--seeds"] + [str(s) for s in seeds]
            + ["--out", os.path.join(OUT, f"slam_replay_{name}")] + (["--setup", setup] if setup else []),
            f"bench_slam_replay_{name}.json")
    return res


LESSON_MAX_URANGE = (2.0, 7.0)   # [m] the course's maxUrange lesson: 2.0 degrades the map, 7.0 does not
LESSON_SIM_SEEDS = (0, 1, 2)


def bench_slam_sim(runs):
    """The live node on the tour (bench_slam_sim.py), then the course's maxUrange lesson
    with the SLAM core offline on the same tour (slam_tour_offline.py, one filter seed per
    simulator seed)."""
    res = _run_script("my_summit_mapping", "bench_slam_sim.py",
                      ["--runs", str(runs), "--speed", "3", "--out", OUT, "--profile"], "bench_slam_sim.json")
    res["max_urange_lesson"] = {}
    for mu in LESSON_MAX_URANGE:
        out = _run_script("my_summit_mapping", "slam_tour_offline.py",
                          ["--sim-seeds"] + [str(s) for s in LESSON_SIM_SEEDS]
                          + ["--filter-seeds", "0", "--set", f"maxUrange={mu:g}"], f"slam_lesson_mu{mu:g}.json",
                          check=False)   # 2 m misses the tour's targets: that is the lesson
        res["max_urange_lesson"][f"{mu:g}"] = out["results"]
    return res


def bench_amcl(runs):
    """The amcl core (bench_amcl_core.py), then the live node on the tour
    (bench_amcl_node.py): median CPU per simulated second of `runs` runs, and one
    profiled run for where the time goes."""
    res = _run_script("my_summit_localization", "bench_amcl_core.py", [], "bench_amcl.json")
    node = _run_script("my_summit_localization", "bench_amcl_node.py", ["--runs", str(runs)], "bench_amcl_node.json")
    shares = _run_script("my_summit_localization", "bench_amcl_node.py",
                         ["--runs", "1", "--sim-time", "30", "--profile", os.path.join(OUT, "amcl_profile")],
                         "bench_amcl_node_profile.json").get("profile_shares")
    res["node"] = {"median": node["median"], "runs": len(node["runs"]), "sim_time": node["sim_time"],
                   "speed": node["speed"], "profile_shares": shares,
                   "real_amcl_cpu_per_sim_s": node["real_amcl_cpu_per_sim_s"]}
    return res


def bench_planning(runs):
    """The path-planning core benchmark; timings are medians over `runs` repeats (the
    closed loop is seeded and deterministic, so it runs once, every planner combination,
    one pair per core at a time, after the timings; each combination is kept in
    output/bench_planning_parts/ as it is done)."""
    res = _run_script("my_summit_path_planning", "bench_planning_core.py",
                      ["--repeats", str(runs), "--runs", "50", "--willow-runs", "20", "--matrix",
                       "--jobs", str(os.cpu_count() or 1), "--parts", os.path.join(OUT, "bench_planning_parts")],
                      "bench_planning.json")
    # For contrast, the built-in world's closed loop at the base's top speed (1.5 m/s):
    # the in-place turns and the acceleration take the same time at any max_vel_x, so
    # they weigh more in the time ratio the faster the robot may drive.
    fast = _run_script("my_summit_path_planning", "bench_planning_core.py",
                       ["--skip-navfn", "--runs", "50", "--max-vel-x", "1.5"], "bench_planning_fast.json")
    res["closed_loop_builtin_fast"] = dict(fast["closed_loop_builtin"], max_vel_x=fast["max_vel_x"])
    for key in [k for k in res if k.startswith("closed_loop_")]:  # the per-run details stay in the JSON files
        res[key] = {k: v for k, v in res[key].items() if k != "runs_detail"}
    return res


EKF_SEEDS = (1, 2, 3, 4, 5)


def bench_ekf(node=None, node_setup=None, seeds=EKF_SEEDS):
    """bench_ekf.py on our ekf_localization_node, or on `node` (node_setup: the bash file its
    environment needs) for ekf_peer. Both play the same recorded tours (output/ekf_bags,
    recorded by the first of them that runs). Ours carries the peer's last medians from the
    store, which its targets compare against."""
    tag = "_peer" if node else ""
    res = _run_script("my_summit_localization", "bench_ekf.py",
                      ["--seeds", *map(str, seeds), "--bags", os.path.join(OUT, "ekf_bags"),
                       "--out", os.path.join(OUT, f"bench_ekf{tag}")]
                      + _node_args(node, node_setup, "--setup"),
                      f"bench_ekf{tag}.json")
    if not node:
        peer = bench_report.load_store().get("sections", {}).get("ekf_peer")
        if peer:
            res["peer"] = {"median": peer["rows"][0]["values"].get("median"), "commit": peer["commit"],
                           "node": peer["rows"][0]["values"].get("node")}
    return res


def bench_ekf_downstream(seeds=EKF_SEEDS):
    """bench_ekf_downstream.py: amcl and slam_gmapping on the raw and on the fused odometry,
    each seed's tour live for each."""
    return _run_script("my_summit_localization", "bench_ekf_downstream.py",
                       ["--seeds", *map(str, seeds), "--out", os.path.join(OUT, "bench_ekf_downstream")],
                       "bench_ekf_downstream.json")


PEER_WILLOW_PAIRS = 20   # planning's closed loop on willow-full-0.05
# (global, local) kinds the peer runs: the lesson's global planner with each local planner
PEER_COMBOS = (("navfn", "dwa"), ("navfn", "trajectory"), ("navfn", "trajectory-dwa"))
# Simulated s per wall s for each local planner: at 3x the real TrajectoryPlannerROS was
# late on 15 control cycles of 20 pairs, its DWAPlannerROS (~20 ms a cycle here) on 4947.
PEER_SPEED = {"dwa": 1.0, "trajectory": 3.0, "trajectory-dwa": 3.0}


def bench_planning_peer(node, node_setup=None):
    """bench_move_base_live.py: the move_base executable `node` (node_setup: the bash file
    its environment needs) live on the willow pairs of planning's closed loop, for each
    PEER_COMBOS combination; {"combos": {"<global>_<local>": result}}."""
    combos = {}
    for global_kind, local_kind in PEER_COMBOS:
        key = f"{global_kind}_{local_kind}"
        combos[key] = _run_script(
            "my_summit_path_planning", "bench_move_base_live.py",
            ["--world", "willow", "--pairs", str(PEER_WILLOW_PAIRS), "--global-planner", global_kind,
             "--local-planner", local_kind, "--speed", str(PEER_SPEED[local_kind]),
             "--out", os.path.join(OUT, "planning_peer", key)]
            + _node_args(node, node_setup), f"bench_planning_peer_{key}.json")
    return {"combos": combos}


STACK_CPU_PROFILE_GOALS = 4   # the profiled run drives the first goals only (the profiler is slow)


def bench_stack_cpu(runs):
    """bench_stack_cpu.py: median of `runs` runs of the 10 goals, then one profiled run of
    move_base over the first STACK_CPU_PROFILE_GOALS goals."""
    res = _run_script("my_summit_path_planning", "bench_stack_cpu.py", ["--runs", str(runs)], "bench_stack_cpu.json")
    prof = _run_script("my_summit_path_planning", "bench_stack_cpu.py",
                       ["--runs", "1", "--goals", str(STACK_CPU_PROFILE_GOALS), "--profile",
                        os.path.join(OUT, "move_base_profile")], "bench_stack_cpu_profile.json")
    res["profile"] = {"goals": prof["goals"], "profile_shares": prof.get("profile_shares"),
                      "threads": prof.get("threads")}
    for r in res["runs"]:   # the per-goal details stay in the script's JSON
        r.pop("goal_results", None)
    return res


def _json_tail(out):
    """The JSON document at the end of a script's output."""
    start = out.rfind("\n{")
    return json.loads(out[start + 1:] if start >= 0 else out)


EXPLORE_RUNS = {"builtin": 5, "willow": 1}   # seeded starts per world
EXPLORE_KARTO_RUNS = {"willow": 1}           # issue 42: the large building, where loops close


def bench_explore(worlds=None, slam="gmapping", node=None, node_setup=None):
    """bench_explore.py on the built-in world (5 seeded starts) and willow-full (1), or
    only `worlds`, at real time: slam_gmapping, move_base on the growing map and explore
    together need about 1.5 cores, so faster than real time starves them on 2 cores.
    node: another SLAM executable run in ours' place (node_setup: the bash file its
    environment needs), for explore_karto_peer; its result is {"node", "worlds"}."""
    script = os.path.join(WS, "src", "my_summit_navigation", "scripts", "bench_explore.py")
    extra = _node_args(node, node_setup)
    res = {}
    for world, runs in (EXPLORE_KARTO_RUNS if slam == "karto" else EXPLORE_RUNS).items():
        if worlds and world not in worlds:
            continue
        path = os.path.join(OUT, f"bench_explore_{slam}{'_peer' if node else ''}_{world}.json")
        subprocess.run([sys.executable, script, "--world", world, "--runs", str(runs), "--speed", "1",
                        "--slam", slam, "--json", path] + extra, check=True)
        with open(path) as f:
            res[world] = json.load(f)
    return {"node": node, "worlds": res} if node else res


def bench_patrol():
    """bench_patrol.py: 10 rounds over the three spots, a box on the route twice."""
    script = os.path.join(WS, "src", "my_summit_navigation", "scripts", "bench_patrol.py")
    path = os.path.join(OUT, "bench_patrol.json")
    subprocess.run([sys.executable, script, "--rounds", "10", "--speed", "1", "--json", path])
    with open(path) as f:
        return json.load(f)


RACE_LAPS = 10
RACE_CAPACITY_WH = 10.0  # [Wh] a lap takes ~20 % of it: 10 laps need at least two charging stops
ADAPTIVE_LAPS = 2
ADAPTIVE_SPEED = 2.0     # the lap times are in simulated time; 2x keeps the comparison short


def bench_race_track():
    """bench_race_track.py: the long cruise with charging stops and a box, then the adaptive
    parameters off and on."""
    script = os.path.join(WS, "src", "my_summit_navigation", "scripts", "bench_race_track.py")
    runs = {"cruise": ["--laps", str(RACE_LAPS), "--speed", "1", "--box", "--capacity-wh", str(RACE_CAPACITY_WH),
                       "--min-charges", "2"],
            "adaptive_off": ["--laps", str(ADAPTIVE_LAPS), "--speed", str(ADAPTIVE_SPEED)],
            "adaptive_on": ["--laps", str(ADAPTIVE_LAPS), "--speed", str(ADAPTIVE_SPEED), "--adaptive"]}
    res = {"capacity_wh": RACE_CAPACITY_WH}
    for name, extra in runs.items():
        path = os.path.join(OUT, f"bench_race_track_{name}.json")
        if os.path.exists(path):
            os.remove(path)     # a run that dies before writing must not leave an old result standing
        subprocess.run([sys.executable, script, "--json", path] + extra)
        if not os.path.exists(path):
            raise RuntimeError(f"bench_race_track.py {' '.join(extra)} wrote no result")
        with open(path) as f:
            res[name] = json.load(f)
    return res


def bench_multi_robot(runs):
    script = os.path.join(WS, "src", "my_summit_navigation", "scripts", "bench_multi_robot.py")
    out = subprocess.run([sys.executable, script, "--runs", str(runs), "--window", "30"], check=True,
                         stdout=subprocess.PIPE, text=True).stdout
    return _json_tail(out)


E2E_SPEED = 4.0  # the course project end to end faster than real time (issue 24's figure)


MEMORY_GOALS = 2        # the stack's run for peak RSS: the first goals of stack_cpu's seeded ten
STARTUP_RUNS = 3        # launches timed for the stack's startup (median)
STARTUP_GOAL = (0.5, 0.0, 0.0)   # [m, m, rad] in the map frame: just ahead of the start pose


def bench_startup_once():
    """Wall seconds from `roslaunch move_base.launch sim:=true` (its own master) to move_base
    accepting a goal (the goal's status ACTIVE or later); one launch, in a child process
    (rospy binds a process to one master)."""
    import rospy
    from actionlib_msgs.msg import GoalStatus
    from move_base_msgs.msg import MoveBaseAction
    from summit_nav_common.ros.action_client import SimpleActionClient
    from summit_nav_common.testing import move_base_client as mt
    from summit_nav_common.testing.roslaunch_session import RoslaunchSession, wait_for, wait_for_sim_time_param

    t0 = time.monotonic()
    with RoslaunchSession(["my_summit_path_planning", "move_base.launch", "sim:=true"],
                          log=os.path.join(OUT, "bench_memory_startup.log")) as session:
        wait_for_sim_time_param(session)
        rospy.init_node("bench_startup", anonymous=True, disable_signals=True)
        client = SimpleActionClient("move_base", MoveBaseAction)
        wait_for(lambda: client.wait_for_server(rospy.Duration(0.1)), 300, "move_base's action server", session)
        accepted = (GoalStatus.ACTIVE, GoalStatus.SUCCEEDED, GoalStatus.PREEMPTED, GoalStatus.ABORTED)
        client.send_goal(mt.make_goal(*STARTUP_GOAL))
        wait_for(lambda: client.get_state() in accepted, 300, "move_base accepting a goal", session, poll=0.01)
        startup_s = time.monotonic() - t0
        client.cancel_all_goals()
    return {"startup_s": startup_s}


def bench_memory(real_stack_json=None):
    """Peak RSS (VmHWM) per node on the benchmark's own runs: map_server, amcl, move_base on
    stack_cpu's run (bench_stack_cpu.py, its first MEMORY_GOALS goals), slam_gmapping on
    slam_bag's Intel bag (seed 1, at BAG_RATE); the stack's startup (STARTUP_RUNS launches,
    launch to move_base accepting a goal). The real nodes' figures: map_server, amcl and
    move_base from real_stack_json (written by the command it names, on the same run with
    the real C++ nodes), slam_gmapping from the stored slam_bag_peer record (the real
    gmapping on the same bag)."""
    stack = _run_script("my_summit_path_planning", "bench_stack_cpu.py", ["--runs", "1", "--goals", str(MEMORY_GOALS)],
                        "bench_memory_stack.json")
    slam = _run_script("my_summit_mapping", "bench_slam_bag.py",
                       [os.path.join(DATA, "carmen", CARMEN_LOGS["intel"]), "--rate", str(BAG_RATE), "--seeds", "1",
                        "--out", os.path.join(OUT, "memory_slam_bag_intel")], "bench_memory_slam.json")
    startup = [_child_json("memory_startup_child") for _ in range(STARTUP_RUNS)]
    ours = {n: stack["median"]["peak_rss_mb"][n] for n in ("map_server", "amcl", "move_base")}
    ours["slam_gmapping"] = slam["median"]["peak_rss_mb"]
    real, sources = {}, {}
    if real_stack_json:
        with open(real_stack_json) as f:
            doc = json.load(f)
        for n in ("map_server", "amcl", "move_base"):
            real[n] = doc["median"]["peak_rss_mb"][n]
            sources[n] = (f"the C++ node on the same {doc['goals']} goals, median of {len(doc['runs'])} runs "
                          f"(real_stack_rss.py --goals {doc['goals']} --runs {len(doc['runs'])} --json)")
    peer = bench_report.load_store()["sections"].get("slam_bag_peer")
    if peer and "intel" in peer["result"]["logs"]:
        real["slam_gmapping"] = peer["result"]["logs"]["intel"]["median"]["peak_rss_mb"]
        sources["slam_gmapping"] = (f"the C++ node on the same bag, median of its seeds: slam_bag_peer at "
                                    f"{peer['commit']}, {peer['date'][:10]}")
    return {"real_stack_json": real_stack_json, "goals": MEMORY_GOALS, "bag_rate": BAG_RATE, "peak_rss_mb": ours, "real_peak_rss_mb": real,
            "real_sources": sources, "startup_s": statistics.median(r["startup_s"] for r in startup),
            "startup_runs": [round(r["startup_s"], 1) for r in startup],
            "stack_reached": stack["reached_min"], "slam_updates": slam["median"].get("updates")}


def _child_json(only):
    """This script run with --only `only` in a child process; the JSON line it prints."""
    r = subprocess.run([sys.executable, __file__, "--only", only], stdout=subprocess.PIPE, text=True, timeout=900)
    line = [l for l in r.stdout.splitlines() if l.startswith("{")]
    if r.returncode != 0 or not line:
        raise RuntimeError(f"{only} failed:\n{r.stdout[-2000:]}")
    return json.loads(line[-1])


def bench_e2e():
    out = subprocess.run([sys.executable, os.path.join(WS, "tools", "e2e_seeds.py"), "--speed", str(E2E_SPEED)]
                         + [str(s) for s in range(1, 11)], stdout=subprocess.PIPE, text=True).stdout
    print(out)
    lines = out.strip().splitlines()
    last = lines[-1]
    skipped = {}   # node -> the most scans it skipped in one run
    wall = []
    for line in lines:
        m = re.search(r"in (\d+) s wall; scans skipped: ([^:]*)", line)
        if m:
            wall.append(int(m.group(1)))
            for node, n in re.findall(r"(\w+) (\d+)", m.group(2)):
                skipped[node] = max(skipped.get(node, 0), int(n))
    return {"speed": E2E_SPEED, "passed": int(last.split()[0]), "failed": int(last.split()[2]),
            "max_scans_skipped": skipped, "wall_s_median": statistics.median(wall) if wall else None,
            "lines": lines}


# The sections that run another executable (the real node) in ours' place: section ->
# (its option, whose --OPTION-setup goes with it; what the executable is).
PEER_SECTIONS = {"slam_bag_peer": ("gmapping", "the real gmapping's slam_gmapping"),
                 "slam_bag_karto_peer": ("karto", "the real slam_karto (build_karto.sh)"),
                 "explore_karto_peer": ("karto", "the real slam_karto (build_karto.sh)"),
                 "slam_replay_peer": ("gmapping-replay", "the real gmapping's slam_gmapping_replay"),
                 "planning_peer": ("move-base", "the real move_base"),
                 "ekf_peer": ("ekf-node", "the real robot_localization's ekf_localization_node")}


def with_node_package(measure, executable, source=None):
    """measure() with the other executable's ROS package, version and sources in its
    result (node_package): the page names it by them, not by its path on this machine.
    source "OWNER/NAME@COMMIT" fills in what the package.xml and checkout do not say."""
    def run():
        from summit_nav_common.testing.provenance import ros_package_of
        result = measure()
        if result is not None:
            pkg = ros_package_of(os.path.abspath(executable)) or {"executable": os.path.basename(executable)}
            if source:
                repository, _, commit = source.partition("@")
                pkg.update(repository=pkg.get("repository") or repository, commit=pkg.get("commit") or commit or None)
            result["node_package"] = pkg
        return result
    return run


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", action="append", help=", ".join(bench_report.SECTIONS) + " (repeatable)")
    ap.add_argument("--runs", type=int, default=5, help="runs per figure (median reported)")
    ap.add_argument("--carmen-logs", nargs="+", metavar="LOG",
                    help="slam_carmen, slam_bag: only these CARMEN logs (intel, aces; default both)")
    ap.add_argument("--bag-rate", type=float, default=BAG_RATE,
                    help=f"slam_bag: rosbag play rate (default {BAG_RATE:g})")
    ap.add_argument("--gmapping", metavar="EXECUTABLE",
                    help="slam_bag_peer: the other slam_gmapping executable (e.g. the real gmapping's)")
    ap.add_argument("--gmapping-setup", metavar="SETUP_BASH",
                    help="slam_bag_peer: a setup.bash the other executable's environment needs")
    ap.add_argument("--karto", metavar="EXECUTABLE",
                    help="slam_bag_karto_peer, explore_karto_peer: the other slam_karto executable (e.g. the real slam_karto's)")
    ap.add_argument("--karto-setup", metavar="SETUP_BASH",
                    help="slam_bag_karto_peer, explore_karto_peer: a setup.bash the other executable's environment needs")
    ap.add_argument("--gmapping-replay", metavar="EXECUTABLE",
                    help="slam_replay_peer: the real gmapping's seeded player slam_gmapping_replay")
    ap.add_argument("--gmapping-replay-setup", metavar="SETUP_BASH",
                    help="slam_replay_peer: a setup.bash the player's environment needs")
    ap.add_argument("--move-base", metavar="EXECUTABLE",
                    help="planning_peer: the other move_base executable (e.g. the real move_base's)")
    ap.add_argument("--move-base-setup", metavar="SETUP_BASH",
                    help="planning_peer: a setup.bash the other executable's environment needs (sourced --extend)")
    ap.add_argument("--ekf-node", metavar="EXECUTABLE",
                    help="ekf_peer: the other ekf_localization_node (e.g. the real robot_localization's)")
    ap.add_argument("--ekf-node-setup", metavar="SETUP_BASH",
                    help="ekf_peer: a setup.bash the other executable's environment needs (sourced --extend)")
    ap.add_argument("--peer-source", metavar="OWNER/NAME@COMMIT",
                    help="*_peer: where the other executable's sources come from (e.g. "
                         "ros-planning/navigation@9ad6441), recorded with its package and version when its "
                         "package.xml or checkout does not say")
    ap.add_argument("--explore-worlds", nargs="+", choices=sorted(EXPLORE_RUNS),
                    help="explore: only these worlds (default all; willow takes about 40 min)")
    ap.add_argument("--real-stack-json", metavar="JSON",
                    help="memory: the real map_server + amcl + move_base's peak RSS on stack_cpu's run "
                         "(real_stack_rss.py --json of the peers' workspace)")
    ap.add_argument("--profile", metavar="PREFIX", help=argparse.SUPPRESS)  # sim_rtf's profiled child
    ap.add_argument("--render", action="store_true",
                    help="only re-render docs/benchmarks.md and the README's table from docs/bench.json")
    args = ap.parse_args()
    if args.render:
        bench_report.render_files(bench_report.load_store())
        print(f"rendered {os.path.relpath(bench_report.PAGE, WS)} and the README's table from "
              f"{os.path.relpath(bench_report.STORE, WS)}")
        return 0
    if args.only == ["memory_startup_child"]:
        print(json.dumps(bench_startup_once()))
        return 0
    if args.only == ["sim_rtf_child"]:
        print(json.dumps(bench_sim_rtf_once(profile=args.profile)))
        return 0
    only = args.only or ["laser", "sim_rtf", "slam_carmen", "slam_bag", "slam_bag_karto", "slam_sim", "amcl", "ekf", "ekf_downstream", "planning", "stack_cpu", "explore", "explore_karto", "patrol",
                         "race_track", "multi_robot"]
    unknown = sorted(set(only) - set(bench_report.SECTIONS))
    if unknown:
        ap.error(f"unknown section(s) {unknown}; known: {', '.join(bench_report.SECTIONS)}")
    for section, (option, what) in PEER_SECTIONS.items():
        if section not in only:
            continue
        exe, setup = getattr(args, option.replace("-", "_")), getattr(args, option.replace("-", "_") + "_setup")
        if not exe:
            ap.error(f"{section} needs --{option} EXECUTABLE ({what}, built outside the project, e.g. by shared "
                     "tools' build_ros_peers.sh)")
        for flag, path in ((f"--{option}", exe), (f"--{option}-setup", setup)):
            if path and not os.path.isfile(path):
                ap.error(f"{flag}: no such file: {path}")
    measures = {
        "laser": lambda: bench_laser(args.runs),
        "sim_rtf": lambda: bench_sim_rtf_runs(max(1, min(args.runs, 3))),
        "slam_carmen": lambda: bench_slam_carmen(args.carmen_logs),
        "slam_bag": lambda: bench_slam_bag(args.carmen_logs, args.bag_rate),
        "slam_bag_peer": lambda: bench_slam_bag(args.carmen_logs, args.bag_rate, node=os.path.abspath(args.gmapping),
                                                node_setup=args.gmapping_setup and os.path.abspath(args.gmapping_setup)),
        "slam_bag_karto": lambda: bench_slam_bag(args.carmen_logs, args.bag_rate, slam="karto"),
        "slam_bag_karto_peer": lambda: bench_slam_bag(args.carmen_logs, args.bag_rate, node=os.path.abspath(args.karto),
                                                      node_setup=args.karto_setup and os.path.abspath(args.karto_setup),
                                                      slam="karto"),
        "slam_replay_peer": lambda: bench_slam_replay(os.path.abspath(args.gmapping_replay),
                                                      args.gmapping_replay_setup
                                                      and os.path.abspath(args.gmapping_replay_setup),
                                                      args.carmen_logs),
        "slam_sim": lambda: bench_slam_sim(args.runs),
        "amcl": lambda: bench_amcl(max(1, min(args.runs, 3))),
        "ekf": bench_ekf,
        "ekf_downstream": bench_ekf_downstream,
        "ekf_peer": lambda: bench_ekf(os.path.abspath(args.ekf_node),
                                      args.ekf_node_setup and os.path.abspath(args.ekf_node_setup)),
        "planning": lambda: bench_planning(args.runs),
        "planning_peer": lambda: bench_planning_peer(os.path.abspath(args.move_base), args.move_base_setup
                                                     and os.path.abspath(args.move_base_setup)),
        "stack_cpu": lambda: bench_stack_cpu(max(1, min(args.runs, 3))),
        "explore": lambda: bench_explore(args.explore_worlds),
        "explore_karto": lambda: bench_explore(args.explore_worlds, slam="karto"),
        "explore_karto_peer": lambda: bench_explore(args.explore_worlds, slam="karto", node=os.path.abspath(args.karto),
                                                    node_setup=args.karto_setup and os.path.abspath(args.karto_setup)),
        "patrol": bench_patrol,
        "race_track": bench_race_track,
        "multi_robot": lambda: bench_multi_robot(min(args.runs, 3)),
        "e2e": bench_e2e,
        "memory": lambda: bench_memory(args.real_stack_json),
    }
    for section, (option, _) in PEER_SECTIONS.items():
        if section in only:
            measures[section] = with_node_package(measures[section], getattr(args, option.replace("-", "_")),
                                                  args.peer_source)
    os.makedirs(OUT, exist_ok=True)
    command = shlex.join(["tools/bench.py"] + sys.argv[1:])
    report = {"machine": bench_report.machine(), "commit": bench_report.git_commit(), "records": {}}
    path = os.path.join(OUT, "bench.json")
    # Sections run in the page's order; each one's record is merged into the store and the
    # page re-rendered as soon as it ends, so a later failure keeps the earlier sections.
    for section in [s for s in bench_report.SECTIONS if s in only]:
        result, rec = bench_report.run_section(section, measures[section], command)
        if result is None:
            raise RuntimeError(f"benchmark section {section} produced no result")
        report[section] = result
        report["records"][section] = rec
        with open(path + ".tmp", "w") as f:
            json.dump(report, f, indent=2)
        os.replace(path + ".tmp", path)
        store = bench_report.merge(bench_report.load_store(), [rec])
        bench_report.save_store(store)
        bench_report.render_files(store)
        print(f"\n{section}: " + bench_report.context_line(rec))
        print("\n".join(bench_report.table(rec["rows"])), flush=True)
    print(f"\nJSON: {os.path.relpath(path, WS)}; store {os.path.relpath(bench_report.STORE, WS)}, page "
          f"{os.path.relpath(bench_report.PAGE, WS)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
