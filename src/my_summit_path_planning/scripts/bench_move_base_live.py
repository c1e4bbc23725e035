#!/usr/bin/python3
"""A move_base node live on bench_planning_core's closed-loop goal pairs, on simulated time.

The same seeded start / goal pairs as the offline closed loop (bench_planning_core.draw_pairs
on the built-in world or willow-full-0.05), each in a fresh ROS graph of its own: a master on
a free port; roslaunch of summit_xl_sim (the world, the pair's start pose and simulator
seed), our map_server on the world's YAML and our fake_localization (ground truth as map ->
odom); and a move_base node started directly (so that /proc/<pid> is the node's own),
named move_base, cmd_vel -> /summit_xl_control/cmd_vel, odom -> /odom, with the package's
config/*.yaml loaded into /move_base as move_base.launch loads them, base_global_planner,
base_local_planner and their namespaces' parameters set as bench_planning_core's
combination_params has them (--global-planner, --local-planner). One goal
through the move_base action (summit_nav_common.ros.action_client.SimpleActionClient, after
the robot has stood for SETTLE_S so the costmaps have seen the laser); recorded: the ground
truth (/base_pose_ground_truth), /collisions, the action's result, the first plan
(~<global planner>/plan), the time to the result in simulated time, the node's CPU seconds,
and a trace of pose and command (pairNN_trace.csv in --out) to see where a pair went wrong.

A pair is reached when the action SUCCEEDED with the robot within xy_goal_tolerance + 0.05 m
and yaw_goal_tolerance + 0.05 rad of the goal (the local planner's config), as the offline
closed loop judges it; a pair is given up after max(TIME_LIMIT_MIN, TIME_LIMIT_FACTOR x
geodesic / max_vel_x) of simulated time (the core's constants). Reported per pair and over
the pairs in the shape of bench_planning_core.summarize: reached share, collisions, medians
of time / (L / max_vel_x) with L the grid geodesic and the first plan's length.

--node EXECUTABLE runs another move_base-compatible executable in place of ours (e.g. the
real move_base, as the oracle on the same pairs and scoring), in the environment a bash has
after `source SETUP_BASH --extend` (--node-setup; a catkin devel/setup.bash then adds its
workspace to this one). Each pair runs in a child process of this script (rospy starts once
per process, and each pair has its own master); every process started is stopped, also on
failure. Bad options end with a message and exit status 2 before anything starts.

Usage: bench_move_base_live.py [--world builtin|willow] [--pairs N] [--only K ...]
           [--global-planner navfn|astar|dijkstra] [--local-planner dwa|trajectory|trajectory-dwa]
           [--speed 1.0]
           [--node EXECUTABLE [--node-setup SETUP_BASH]] [--json PATH] [--out DIR]
  e.g. bench_move_base_live.py --world willow --only 2 13
       bench_move_base_live.py --world willow --node /tmp/peers_ws/devel/lib/move_base/move_base \\
           --node-setup /tmp/peers_ws/devel/setup.bash --json output/move_base_real_willow.json
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import threading
import time

import bench_planning_core as core  # a sibling script: the pairs, the planner kinds, the time limit
from summit_nav_common.files import write_atomic
from summit_nav_common.geometry import quaternion_to_yaw
from summit_nav_common.testing.roslaunch_session import check_node_args, child_result, exit_on_sigterm, print_result

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.abspath(os.path.join(HERE, "..", "..", ".."))

NODE = os.path.normpath(os.path.join(HERE, "..", "nodes", "move_base"))
NODE_NAME = "move_base"
WORLDS = dict(core.WORLDS)
DEFAULT_PAIRS = {"builtin": 50, "willow": 20}   # bench_planning's closed loop
CMD_VEL = "/summit_xl_control/cmd_vel"   # the simulator's command topic (move_base's cmd_vel remapped to it)
REMAPS = (f"cmd_vel:={CMD_VEL}", "odom:=/odom")
# The config files in the order move_base.launch loads them: (file, namespace under /move_base).
CONFIG_FILES = (("move_base_params.yaml", ""), ("costmap_common_params.yaml", "global_costmap"),
                ("costmap_common_params.yaml", "local_costmap"), ("global_costmap_params.yaml", ""),
                ("local_costmap_params.yaml", ""), ("navfn_global_planner_params.yaml", ""),
                ("dwa_local_planner_params.yaml", ""), ("base_local_planner_params.yaml", ""))
GOAL_MARGIN_XY = 0.05     # [m] reached: within xy_goal_tolerance + this (as the offline closed loop)
GOAL_MARGIN_YAW = 0.05    # [rad] ... and yaw_goal_tolerance + this
START_TIMEOUT = 120.0     # [s wall] for the launch and the move_base action server
SETTLE_S = 3.0            # [s sim] the robot stands this long before its goal (costmaps see the laser)
WALL_FACTOR = 20.0        # a pair is stopped after this x its sim time limit of wall time (a stalled clock)
POLL_S = 0.02             # [s wall]
TRACE_DT = 0.2            # [s sim] the trace's sampling (pairNN_trace.csv beside the logs)
SUCCEEDED = 3             # actionlib_msgs/GoalStatus
STATE_NAMES = {0: "PENDING", 1: "ACTIVE", 2: "PREEMPTED", 3: "SUCCEEDED", 4: "ABORTED", 5: "REJECTED",
               6: "PREEMPTING", 7: "RECALLING", 8: "RECALLED", 9: "LOST"}

LAUNCH = """<launch>
  <include file="$(find summit_xl_sim)/launch/sim.launch">
    <arg name="world" value="{world}"/>
    <arg name="x" value="{x!r}"/><arg name="y" value="{y!r}"/><arg name="yaw" value="{yaw!r}"/>
    <arg name="seed" value="{seed}"/><arg name="speed" value="{speed!r}"/>
  </include>
  <node pkg="my_summit_mapping" type="map_server" name="map_server" args="{world}" required="true"/>
  <node pkg="my_summit_localization" type="fake_localization" name="fake_localization" required="true">
    <param name="odom_frame_id" value="odom"/>
    <param name="base_frame_id" value="base_footprint"/>
    <param name="global_frame_id" value="map"/>
  </node>
</launch>
"""


# ----------------------------------------------------------------- judging
def combination(global_kind, local_kind):
    """The config's MoveBaseParams as bench_planning_core.combination_params sets them for
    these planner kinds (GLOBAL_KINDS with the course's NavfnROS choices, LOCAL_KINDS)."""
    from my_summit_path_planning.params import load_move_base_params
    return core.combination_params(load_move_base_params(core.CONFIG), global_kind, local_kind)


def goal_rule(global_kind, local_kind):
    """The local planner's xy_goal_tolerance [m], yaw_goal_tolerance [rad] and max_vel_x
    [m/s] as the config and LOCAL_KINDS give them, and both planners' type strings."""
    from my_summit_path_planning.params import build_costmap
    from my_summit_path_planning.plugins import MoveBasePlugins
    p = combination(global_kind, local_kind)
    plugins = MoveBasePlugins(p, footprint=build_costmap(p.local_costmap, "local_costmap").footprint)
    cfg = plugins.local_planner.config
    return {"local_type": plugins.local_type, "global_type": plugins.global_type,
            "xy_goal_tolerance": cfg.xy_goal_tolerance, "yaw_goal_tolerance": cfg.yaw_goal_tolerance,
            "max_vel_x": cfg.max_vel_x}


def time_limit(geodesic_m, max_vel_x):
    """[s sim] a pair is given up after this (the offline closed loop's rule on the geodesic)."""
    return max(core.TIME_LIMIT_MIN, core.TIME_LIMIT_FACTOR * geodesic_m / max_vel_x)


def judge(rec, rule):
    """rec (a pair's record: state, final pose, goal, time_s, geodesic_m, plan_m, done) with
    reached, failure, errors and the time ratios added, by the rule (goal_rule)."""
    (x, y, yaw), (gx, gy, gyaw) = rec["final"], rec["goal"]
    err = math.hypot(x - gx, y - gy)
    yaw_err = abs(math.atan2(math.sin(yaw - gyaw), math.cos(yaw - gyaw)))
    succeeded = rec["state"] == SUCCEEDED
    ok = succeeded and err <= rule["xy_goal_tolerance"] + GOAL_MARGIN_XY \
        and yaw_err <= rule["yaw_goal_tolerance"] + GOAL_MARGIN_YAW
    state = STATE_NAMES.get(rec["state"], str(rec["state"]))
    failure = ("" if ok else "goal reported reached out of tolerance" if succeeded else
               f"{state.lower()}: {rec['text']}" if rec["done"] else f"timeout ({rec['limit_s']:.0f} s)")
    vmax = rule["max_vel_x"]
    return dict(rec, reached=bool(ok), failure=failure, xy_error_m=err, yaw_error_rad=yaw_err,
                geodesic_ratio=rec["time_s"] / (rec["geodesic_m"] / vmax),
                ratio=rec["time_s"] / (rec["plan_m"] / vmax) if rec.get("plan_m") else None)


def summarize(header, runs):
    """The pairs' figures in the shape of bench_planning_core.summarize (the plan ratio's
    median over the runs that had a plan), plus the failed pair numbers and the node's CPU."""
    def median(xs):
        xs = [x for x in xs if x is not None]
        return float(statistics.median(xs)) if xs else None
    cpu = [r.get("cpu_s") for r in runs]
    return {**header, "runs": len(runs),
            "reached_share": sum(r["reached"] for r in runs) / max(1, len(runs)),
            "collisions": int(sum(r["collisions"] for r in runs)),
            "ratio_median": median(r.get("ratio") for r in runs),
            "geodesic_ratio_median": median(r["geodesic_ratio"] for r in runs),
            "failed_pairs": [r["pair"] for r in runs if not r["reached"]],
            "cpu_s": sum(cpu) if runs and None not in cpu else None,
            "late_cycles": (None if any(r.get("late_cycles") is None for r in runs)
                            else sum(r["late_cycles"] for r in runs)),
            "runs_detail": runs}


# ----------------------------------------------------------------- one pair (child process)
def node_command(node=None):
    """Command line of the move_base under test: ours (nodes/move_base, run by this Python)
    or `node`, another move_base-compatible executable, run directly."""
    return ([sys.executable, NODE] if node is None else [node]) + [f"__name:={NODE_NAME}", *REMAPS]


def load_node_params(global_kind, local_kind):
    """The config's files into /move_base (CONFIG_FILES, as move_base.launch: dictionaries
    merged), then base_global_planner / base_local_planner and their namespaces' parameters
    as combination() has them."""
    import rosparam
    from my_summit_path_planning.nav_core import namespace_of
    for name, ns in CONFIG_FILES:
        for params, where in rosparam.load_file(os.path.join(core.CONFIG, name),
                                                default_namespace=f"/{NODE_NAME}/{ns}".rstrip("/") + "/"):
            rosparam.upload_params(where, params)
    p = combination(global_kind, local_kind)
    for key in ("base_global_planner", "base_local_planner"):
        type_name = getattr(p.move_base, key)
        ns = namespace_of(type_name)
        rosparam.set_param_raw(f"/{NODE_NAME}/{key}", type_name)
        for k, v in (p.namespaces.get(ns) or {}).items():
            rosparam.set_param_raw(f"/{NODE_NAME}/{ns}/{k}", v)


class Recorder:
    """Ground truth, /collisions, the first plan and the command of the running graph; while
    counting, a trace of (t, x, y, yaw, commanded vx, wz) every TRACE_DT of simulated time."""

    def __init__(self, plan_topic):
        import rospy
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry, Path
        from std_msgs.msg import UInt32
        self.lock = threading.Lock()
        self.pose, self.collisions, self.plan_m, self.driven_m, self.counting = None, None, None, 0.0, False
        self.cmd, self.trace = (0.0, 0.0), []
        self.subs = [rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on_truth, queue_size=10),
                     rospy.Subscriber("/collisions", UInt32, self._on_collisions, queue_size=10),
                     rospy.Subscriber(plan_topic, Path, self._on_plan, queue_size=1),
                     rospy.Subscriber(CMD_VEL, Twist, self._on_cmd, queue_size=10)]

    def _on_truth(self, m):
        pose = (m.pose.pose.position.x, m.pose.pose.position.y, quaternion_to_yaw(m.pose.pose.orientation))
        t = m.header.stamp.to_sec()
        with self.lock:
            if self.counting and self.pose is not None:
                self.driven_m += math.hypot(pose[0] - self.pose[0], pose[1] - self.pose[1])
            if self.counting and (not self.trace or t - self.trace[-1][0] >= TRACE_DT):
                self.trace.append((t,) + pose + self.cmd)
            self.pose = pose

    def _on_cmd(self, m):
        with self.lock:
            self.cmd = (m.linear.x, m.angular.z)

    def write_trace(self, path, t0):
        """The trace as CSV (time from the goal), written whole or not at all."""
        with self.lock:
            rows = list(self.trace)
        write_atomic(path, "t,x,y,yaw,cmd_vx,cmd_wz\n" + "".join(
            f"{t - t0:.2f},{x:.3f},{y:.3f},{yaw:.3f},{vx:.3f},{wz:.3f}\n" for t, x, y, yaw, vx, wz in rows))

    def _on_collisions(self, m):
        with self.lock:
            self.collisions = m.data

    def _on_plan(self, m):
        with self.lock:
            if self.counting and self.plan_m is None and len(m.poses) > 1:
                pts = [(p.pose.position.x, p.pose.position.y) for p in m.poses]
                self.plan_m = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:]))


def run_pair(world_yaml, pair, k, global_kind, local_kind, rule, out, speed=1.0, node=None, node_setup=None):
    """Pair number k (1-based) live: launch, move_base, one goal (module docstring); the
    judged record (judge)."""
    from summit_nav_common.testing.roslaunch_session import (RoslaunchSession, Watched, cpu_seconds, sourced_env,
                                                             stop_process_tree, wait_for, wait_for_sim_time_param)
    from my_summit_path_planning.nav_core import namespace_of
    (sx, sy, syaw), (gx, gy, gyaw) = pair["start"], pair["goal"]
    limit = time_limit(pair["geodesic_m"], rule["max_vel_x"])
    stem = os.path.join(out, f"pair{k:02d}")
    with open(stem + ".launch", "w") as f:
        f.write(LAUNCH.format(world=os.path.abspath(world_yaml), x=sx, y=sy, yaw=syaw, seed=pair["sim_seed"],
                              speed=float(speed)))
    node_proc, rospy = None, None
    with RoslaunchSession([stem + ".launch"], log=stem + "_launch.log") as session:
        try:
            wait_for_sim_time_param(session, START_TIMEOUT)
            load_node_params(global_kind, local_kind)
            env = sourced_env(node_setup, session.env, extend=True) if node_setup else session.env
            env = dict(env, ROS_MASTER_URI=session.env["ROS_MASTER_URI"])
            with open(stem + "_move_base.log", "w") as log:
                node_proc = subprocess.Popen(node_command(node), stdout=log, stderr=subprocess.STDOUT, env=env,
                                             start_new_session=True)
            alive = (session, Watched.process(NODE_NAME, node_proc, stem + "_move_base.log"))
            import rospy
            from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
            from summit_nav_common.ros.action_client import SimpleActionClient
            rospy.init_node("bench_move_base_live", anonymous=True, disable_signals=True)
            rec = Recorder(f"/{NODE_NAME}/{namespace_of(rule['global_type'])}/plan")
            client = SimpleActionClient(f"/{NODE_NAME}", MoveBaseAction)
            wait_for(lambda: rec.pose is not None and rec.collisions is not None and rospy.Time.now().to_sec() > 0,
                     START_TIMEOUT, "ground truth, /collisions and /clock", alive, POLL_S)
            wait_for(lambda: client.wait_for_server(rospy.Duration(0.1)), START_TIMEOUT,
                     "the move_base action server", alive, POLL_S)
            settle = rospy.Time.now().to_sec() + SETTLE_S
            wait_for(lambda: rospy.Time.now().to_sec() >= settle, START_TIMEOUT, "the robot to settle", alive, POLL_S)
            goal = MoveBaseGoal()
            goal.target_pose.header.frame_id = "map"
            goal.target_pose.header.stamp = rospy.Time.now()
            goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = gx, gy
            goal.target_pose.pose.orientation.z = math.sin(gyaw / 2.0)
            goal.target_pose.pose.orientation.w = math.cos(gyaw / 2.0)
            done = []
            with rec.lock:
                coll0, rec.counting = rec.collisions, True
            cpu0, t0, wall0 = cpu_seconds(node_proc.pid), rospy.Time.now().to_sec(), time.monotonic()
            client.send_goal(goal, done_cb=lambda state, result: done.append(rospy.Time.now().to_sec() - t0))
            wait_for(lambda: done or rospy.Time.now().to_sec() - t0 >= limit
                     or time.monotonic() - wall0 > WALL_FACTOR * limit, 1e9, "the result", alive, POLL_S)
            t_end = done[0] if done else rospy.Time.now().to_sec() - t0
            cpu = cpu_seconds(node_proc.pid) - cpu0
            if not done:
                client.cancel_goal()
            with rec.lock:
                final, coll, plan_m, driven = rec.pose, rec.collisions - coll0, rec.plan_m, rec.driven_m
            state, text = client.get_state(), client.get_goal_status_text()
            rec.write_trace(stem + "_trace.csv", t0)
        finally:
            stop_process_tree(node_proc, grace=10.0)
            if rospy is not None:
                rospy.signal_shutdown("bench_move_base_live: pair over")
    return judge({"pair": k, "start": [sx, sy, syaw], "goal": [gx, gy, gyaw], "geodesic_m": pair["geodesic_m"],
                  "sim_seed": pair["sim_seed"], "limit_s": limit, "done": bool(done), "state": state, "text": text,
                  "time_s": t_end, "final": list(final), "collisions": int(coll), "plan_m": plan_m,
                  "driven_m": driven, "cpu_s": cpu, "wall_s": time.monotonic() - wall0,
                  "late_cycles": late_cycles(stem + "_move_base.log")}, rule)


LATE_CYCLE = "Control loop missed its desired rate"   # move_base's warning (the real one's words, and ours)


def late_cycles(log_path):
    """How often the node said its control loop missed controller_frequency: a node that
    cannot keep up with the simulated speed is judged on a slower controller than it has."""
    try:
        with open(log_path, errors="replace") as f:
            return sum(line.count(LATE_CYCLE) for line in f)
    except OSError:
        return None


# ----------------------------------------------------------------- the pairs (parent)
def parse_args(argv):
    """(args, error text or None): the options checked before anything starts."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--world", default="willow", help="builtin or willow (willow-full-0.05)")
    ap.add_argument("--pairs", type=int, help="pairs drawn (default: 50 built-in, 20 willow, as bench_planning)")
    ap.add_argument("--only", type=int, nargs="+", metavar="K", help="run only these pair numbers (1-based)")
    ap.add_argument("--seed", type=int, default=0, help="the pairs' seed (bench_planning_core's --seed)")
    ap.add_argument("--global-planner", default="navfn", help="navfn, astar or dijkstra (GLOBAL_KINDS)")
    ap.add_argument("--local-planner", default="dwa", help="dwa, trajectory or trajectory-dwa (LOCAL_KINDS)")
    ap.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall second")
    ap.add_argument("--node", metavar="EXECUTABLE", help="run this move_base-compatible executable instead of ours")
    ap.add_argument("--node-setup", metavar="SETUP_BASH",
                    help="source this file (--extend; e.g. a catkin devel/setup.bash) for --node's environment")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--out", help="directory for the logs (default output/move_base_live)")
    ap.add_argument("--child", help=argparse.SUPPRESS)   # one pair as JSON: run it in this process
    args = ap.parse_args(argv)
    if args.world not in WORLDS:
        return args, f"--world {args.world}: unknown; expected one of {', '.join(WORLDS)}"
    if args.global_planner not in core.GLOBAL_KINDS:
        return args, f"--global-planner {args.global_planner}: unknown; expected one of {', '.join(core.GLOBAL_KINDS)}"
    if args.local_planner not in core.LOCAL_KINDS:
        return args, f"--local-planner {args.local_planner}: unknown; expected one of {', '.join(core.LOCAL_KINDS)}"
    args.pairs = DEFAULT_PAIRS[args.world] if args.pairs is None else args.pairs
    if args.pairs < 1:
        return args, f"--pairs must be >= 1, got {args.pairs}"
    bad = [k for k in args.only or () if not 1 <= k <= args.pairs]
    if bad:
        return args, f"--only {' '.join(map(str, bad))}: pair numbers run from 1 to --pairs {args.pairs}"
    if not (args.speed > 0.0 and math.isfinite(args.speed)):
        return args, f"--speed must be a finite number > 0, got {args.speed}"
    try:
        check_node_args(args.node, args.node_setup)
    except ValueError as e:
        return args, str(e)
    return args, None


def child_command(args, k, pair, out):
    return [sys.executable, os.path.abspath(__file__), "--world", args.world, "--global-planner", args.global_planner,
            "--local-planner", args.local_planner,
            "--speed", repr(args.speed), "--out", out, "--child", json.dumps(dict(pair, pair=k))] \
        + (["--node", os.path.abspath(args.node)] if args.node else []) \
        + (["--node-setup", os.path.abspath(args.node_setup)] if args.node_setup else [])


def main(argv=None):
    args, error = parse_args(argv)
    if error:
        print(f"bench_move_base_live: error: {error}", file=sys.stderr)
        return 2
    world_yaml = WORLDS[args.world]
    out = os.path.abspath(args.out or os.path.join(WS, "output", "move_base_live"))
    os.makedirs(out, exist_ok=True)
    rule = goal_rule(args.global_planner, args.local_planner)
    if args.child:   # one pair, in its own process (rospy starts once per process)
        pair = json.loads(args.child)
        try:
            r = run_pair(world_yaml, pair, pair["pair"], args.global_planner, args.local_planner, rule, out,
                         args.speed, args.node, args.node_setup)
        except (RuntimeError, ValueError, OSError) as e:
            print(f"bench_move_base_live: error: pair {pair['pair']}: {e}", flush=True)
            return 1
        print_result(r)
        return 0
    from my_summit_path_planning.params import load_move_base_params
    pairs = core.draw_pairs(load_move_base_params(core.CONFIG), world_yaml, args.pairs, args.seed)
    node = args.node or NODE
    print(f"{os.path.basename(world_yaml)}: {args.pairs} pairs (seed {args.seed}), move_base {node}, "
          f"{rule['global_type']} + {rule['local_type']}, max_vel_x {rule['max_vel_x']} m/s; logs in {out}", flush=True)
    runs = []
    for k, pair in enumerate(pairs, 1):
        if args.only and k not in args.only:
            continue
        r, failure = child_result(child_command(args, k, pair, out))
        if r is None:
            print(f"bench_move_base_live: pair {k} failed ({failure}", file=sys.stderr)
            return 1
        runs.append(r)
        plan = "-" if r["ratio"] is None else f"{r['ratio']:.2f}"
        print(f"  pair {k:2d}: reached={r['reached']} t={r['time_s']:6.1f}s geodesic {r['geodesic_m']:5.1f} m "
              f"ratio {r['geodesic_ratio']:.2f} (plan {plan}) coll={r['collisions']} err={r['xy_error_m']:.3f} m "
              f"{r['yaw_error_rad']:.3f} rad driven {r['driven_m']:.1f} m CPU {r['cpu_s']:.1f} s {r['failure']}",
              flush=True)
    header = {"world": world_yaml, "global_planner": args.global_planner, "local_planner": args.local_planner,
              "global_type": rule["global_type"], "local_type": rule["local_type"], "max_vel_x": rule["max_vel_x"],
              "node": node, "pairs_drawn": args.pairs, "seed": args.seed, "speed": args.speed}
    res = summarize(header, runs)
    geo, plan = res["geodesic_ratio_median"], res["ratio_median"]
    print(f"reached {res['reached_share'] * 100:.0f}% of {res['runs']}, {res['collisions']} collisions, time / "
          f"(L / max_vel_x) median: L geodesic {core._r(geo)}, L plan {core._r(plan)}; failed pairs "
          f"{res['failed_pairs']}", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    exit_on_sigterm()   # a kill stops the graphs this run started
    sys.exit(main())
