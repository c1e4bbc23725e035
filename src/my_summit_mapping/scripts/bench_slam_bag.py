#!/usr/bin/python3
"""Benchmark the live slam_gmapping (or slam_karto) node on a CARMEN log played from a rosbag.

As the real gmapping node is evaluated on these logs: the log becomes a bag
(carmen_to_bag.py: /scan, odom -> base_link with seeded drift, base_link -> base_laser,
/reference_pose), a roscore on a free port, slam_gmapping (nodes/slam_gmapping) with
  particles 30, delta 0.05, linearUpdate 0.2, angularUpdate 0.1,
  maxUrange = min(no-return range - 0.01, 50), maxRange = no-return range + 0.01,
  xmin..ymax = the reference trajectory's bounding box + MAP_MARGIN, seed = the run's seed,
  everything else gmapping's defaults,
and `rosbag play --clock -r RATE` (0.5 in the standard evaluation). Recorded: map -> odom
from /tf, the last /map. Reported per seed:
  - online ATE [m]: map -> odom as broadcast before the next scan, composed with the scan's
    odometry, RMSE after the best rigid 2D alignment to the corrected poses
    (my_summit_mapping.online_eval), over every scan;
  - the drifted odometry's ATE [m] over the same scans, for contrast;
  - the node's CPU seconds (utime + stime from /proc/<pid>/stat, from the first message
    played until it is idle after the bag), CPU per filter update, peak RSS (VmHWM);
  - filter updates done (counted from the map -> odom broadcasts) and expected (gmapping's
    linearUpdate / angularUpdate gate on the odometry), a PNG of the final map.
With several seeds (each: drift seed + ODOM_SEED_OFFSET, filter seed) the median and worst
are reported.

--slam karto runs slam_karto (nodes/slam_karto) on the same bags and scoring, as the real
slam_karto node is run beside the real gmapping: its own defaults with the same frames and
resolution (resolution 0.05, base_frame base_link, odom_frame odom). Its updates are the
scans added to the pose graph (the gate: open_karto's minimum_travel_distance 0.2 m /
minimum_travel_heading 0.174 rad); for ours they are read from the graph it serializes at
the end (~serialize_map), which also gives the final trajectory: the graph's node poses
after its last optimization, scored against the corrected poses of their scans
(ate_final_m) beside the online ATE. For another slam_karto executable (--node, e.g. the
real one) updates are counted from the map -> odom broadcasts and the final ATE is n/a.

--node EXECUTABLE runs another slam_gmapping-compatible executable in place of ours (e.g. the
real gmapping's, as an oracle on the same bags and scoring), with the same parameters; it
is started directly (its pid is the one /proc is read for) as node `slam_gmapping`, in the
environment a bash has after sourcing --node-setup (e.g. its catkin workspace's
devel/setup.bash), when given. The real node ignores `~seed`: its filter is unseeded, and
only the bag's odometry drift follows the seed. Its updates are counted from its log, the
lines GMapping's GridSlamProcessor prints at each one ("update frame N"), "n/a" when there
are none: counted from map -> odom, two updates within one transform_publish_period count
as one, as they do when the real node works off a backlog of scans after its map update
(which runs in its scan callback).

Every process started here is stopped, also on failure; a node crash, bad input or a
timeout ends with a message and a non-zero exit status.

Usage: bench_slam_bag.py LOG [--seeds 1 2 3] [--rate 0.5] [--json PATH] [--out DIR]
                             [--set name=value ...] [--duration S] [--slam gmapping|karto]
                             [--node EXECUTABLE [--node-setup SETUP_BASH]]
  LOG: a CARMEN log (.log / .log.gz) or a bag written by carmen_to_bag.py.
  e.g. bench_slam_bag.py data/carmen/intel-corrected.log.gz --seeds 1 2 --rate 4
       bench_slam_bag.py data/carmen/aces-corrected.log.gz --rate 4 --out output/slam_bag_real \
           --node /tmp/peers_ws/devel/lib/gmapping/slam_gmapping --node-setup /tmp/peers_ws/devel/setup.bash
       bench_slam_bag.py data/carmen/intel-corrected.log.gz --slam karto --seeds 1 2 3 4 5 --rate 4
"""
import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

from summit_nav_common.testing.roslaunch_session import (Watched, check_alive, check_node_args, child_result,
                                                         cpu_seconds, exit_on_sigterm, print_result, sourced_env,
                                                         tail, wait_for)

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.abspath(os.path.join(HERE, "..", "..", ".."))

NODE = os.path.join(HERE, "..", "nodes", "slam_gmapping")
NODE_NAME = "slam_gmapping"
EVAL_PARAMS = dict(particles=30, delta=0.05, linearUpdate=0.2, angularUpdate=0.1,
                   base_frame="base_link", odom_frame="odom")
# --slam karto: slam_karto's defaults but for the frames and resolution (as the real one is run)
KARTO_NODE = os.path.join(HERE, "..", "nodes", "slam_karto")
KARTO_NAME = "slam_karto"
KARTO_EVAL_PARAMS = dict(resolution=0.05, base_frame="base_link", odom_frame="odom")
KARTO_GATE = (0.2, 0.174)   # open_karto's minimum_travel_distance [m] / _heading [rad] defaults
SLAMS = {"gmapping": (NODE, NODE_NAME), "karto": (KARTO_NODE, KARTO_NAME)}
SERIALIZE_TIMEOUT = 120.0   # [s wall] for ~serialize_map at the end of a karto run
STAMP_MATCH = 1e-6          # [s] a graph node's stamp is its scan's (both from the message header)
MAX_URANGE_CAP = 50.0   # [m] maxUrange at most this (the evaluation's setting)
RANGE_MARGIN = 0.01     # [m] maxUrange = no-return - this, maxRange = no-return + this
MAP_MARGIN = 5.0        # [m] around the reference trajectory for xmin..ymax
START_TIMEOUT = 60.0    # [s wall] for roscore and the node to come up
IDLE_CPU = 0.05         # [s CPU] the node counts as idle when it used less than this ...
IDLE_WINDOW = 2.0       # [s wall] ... over this long after the bag ended
IDLE_TIMEOUT = 120.0    # [s wall] at most this long waiting for it to be idle
TIMEOUT_FACTOR = 2.0    # the run may take this many times the bag's duration / rate (+ START_TIMEOUT)
CLOCK_TAIL = 2.0        # [s sim] /clock kept running after the bag (the node's map -> odom
                        # broadcasts run on sim time: without it the last update is never sent)
CLOCK_TAIL_STEP = 0.01  # [s sim] between those /clock messages, published in real time


# ----------------------------------------------------------------- /proc of the node
def peak_rss_mb(pid):
    """Peak resident memory (VmHWM) [MB] of a process."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError(f"no VmHWM in /proc/{pid}/status")


# ----------------------------------------------------------------- parameters
def node_params(scans, overrides=None, slam="gmapping"):
    """The node's parameters for these scans (module docstring), then overrides."""
    if slam == "karto":
        return dict(KARTO_EVAL_PARAMS, **(overrides or {}))
    no_return = float(scans.range_max)
    ref = scans.reference
    lo, hi = ref[:, :2].min(axis=0) - MAP_MARGIN, ref[:, :2].max(axis=0) + MAP_MARGIN
    params = dict(EVAL_PARAMS, maxUrange=min(no_return - RANGE_MARGIN, MAX_URANGE_CAP),
                  maxRange=no_return + RANGE_MARGIN, xmin=float(np.floor(lo[0])), ymin=float(np.floor(lo[1])),
                  xmax=float(np.ceil(hi[0])), ymax=float(np.ceil(hi[1])))
    params.update(overrides or {})
    return params


def parse_set(items):
    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"--set expects name=value, got {item!r}")
        key, value = item.split("=", 1)
        try:
            out[key] = int(value)
        except ValueError:
            try:
                out[key] = float(value)
            except ValueError:
                out[key] = value
    return out


# ----------------------------------------------------------------- the node under test
def node_command(node=None, slam="gmapping"):
    """Command line of the node under test: ours (nodes/slam_gmapping or nodes/slam_karto,
    run by this Python) or `node`, another executable with that node's interface, run directly."""
    path, name = SLAMS[slam]
    return ([sys.executable, path] if node is None else [node]) + [f"__name:={name}"]


def final_graph(service, path, scans):
    """The pose graph a slam_karto node saves through `service` (~serialize_map) to
    path.posegraph at the end of a run: (node poses (N, 3) after its last optimization, the
    index of each node's scan in `scans`, matched by stamp)."""
    import rospy
    from my_summit_mapping.karto.mapper import KartoMapper
    from my_summit_mapping.srv import SerializePoseGraph
    rospy.wait_for_service(service, timeout=SERIALIZE_TIMEOUT)
    rospy.ServiceProxy(service, SerializePoseGraph)(filename=path)
    graph = KartoMapper.load(path + ".posegraph")
    poses = np.asarray(graph.node_poses(), float).reshape(-1, 3)
    stamps = np.asarray(graph.node_stamps(), float)
    index = np.clip(np.searchsorted(scans.stamps, stamps), 0, len(scans.stamps) - 1)
    near = np.abs(scans.stamps[index] - stamps) <= STAMP_MATCH
    before = np.abs(scans.stamps[index - 1] - stamps) <= STAMP_MATCH
    index = np.where(near, index, index - 1)
    if not np.all(near | before):
        raise RuntimeError(f"{path}.posegraph: a node's stamp matches no scan of the bag")
    return poses, index


GMAPPING_UPDATE = re.compile(r"update frame \d+")  # GridSlamProcessor::processScan, once per update


def node_log_updates(path):
    """Filter updates a node reports in its log (GMAPPING_UPDATE, anywhere in a line: its
    stdout and stderr interleave); None when there are none."""
    with open(path, errors="replace") as f:
        return len(GMAPPING_UPDATE.findall(f.read())) or None


# ----------------------------------------------------------------- one run (child process)
class Recorder:
    """map -> odom from /tf, the last /map, and the reference poses seen (so that rosbag
    play --wait-for-subscribers has a subscriber for every topic of the bag)."""

    def __init__(self, map_frame="map", odom_frame="odom"):
        import rospy
        from nav_msgs.msg import OccupancyGrid
        from geometry_msgs.msg import PoseStamped
        from rospy.numpy_msg import numpy_msg
        from tf2_msgs.msg import TFMessage
        self.frames = (map_frame, odom_frame)
        self.lock = threading.Lock()
        self.m2o = []          # (stamp [s], x [m], y [m], yaw [rad]) in arrival order
        self.map_msg = None
        self.maps = 0
        self.references = 0
        self.subs = [rospy.Subscriber("/tf", TFMessage, self._on_tf, queue_size=1000),
                     rospy.Subscriber("/map", numpy_msg(OccupancyGrid), self._on_map, queue_size=1,
                                      buff_size=2 ** 25),
                     rospy.Subscriber("/reference_pose", PoseStamped, self._on_ref, queue_size=100)]

    def _on_tf(self, msg):
        for t in msg.transforms:
            if (t.header.frame_id.lstrip("/"), t.child_frame_id.lstrip("/")) == self.frames:
                q = t.transform.rotation
                yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
                with self.lock:
                    self.m2o.append((t.header.stamp.to_sec(), t.transform.translation.x,
                                     t.transform.translation.y, yaw))

    def _on_map(self, msg):
        with self.lock:
            self.map_msg = msg
            self.maps += 1

    def _on_ref(self, _msg):
        with self.lock:
            self.references += 1


def run_once(bag, seed, rate, overrides, out_dir, node_cmd=None, node_setup=None, slam="gmapping"):
    """Play `bag` through slam_gmapping or slam_karto (ours, or node_cmd in the environment
    node_setup leaves) once; returns the result dict (see module docstring)."""
    from summit_nav_common.testing.roslaunch_session import Roscore, stop_process_tree
    from my_summit_mapping import carmen_bag, online_eval

    node_name = SLAMS[slam][1]
    scans = carmen_bag.read_bag(bag)
    params = node_params(scans, overrides, slam)
    graph = None
    logs = {k: os.path.join(out_dir, f"slam_bag_seed{seed}_{k}.log") for k in ("roscore", "node", "play")}
    roscore = Roscore(log=logs["roscore"], timeout=START_TIMEOUT, caller="/bench_slam_bag")
    env = roscore.env
    os.environ["ROS_MASTER_URI"] = env["ROS_MASTER_URI"]   # rospy in this process
    procs = []

    def start(name, args, child_env=None):
        child_env = dict(child_env or env, ROS_MASTER_URI=env["ROS_MASTER_URI"])
        with open(logs[name], "w") as log:
            p = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, env=child_env, start_new_session=True)
        procs.append(p)
        return p

    try:
        import rospy
        roscore.start()
        master = roscore.master
        master.setParam("/use_sim_time", True)
        for k, v in params.items():
            master.setParam(f"/{node_name}/{k}", v)
        if slam == "gmapping":
            master.setParam(f"/{node_name}/seed", int(seed))
        node = start("node", node_command(node_cmd, slam),
                     sourced_env(node_setup, env) if node_setup else None)
        alive = [roscore, Watched.process(node_name, node, logs["node"])]
        rospy.init_node("bench_slam_bag", anonymous=True, disable_signals=True)
        rec = Recorder()
        from rosgraph_msgs.msg import Clock
        clock_pub = rospy.Publisher("/clock", Clock, queue_size=10)

        def node_subscribed():
            subs = dict((t, n) for t, n in master.getSystemState()[1])
            return f"/{node_name}" in subs.get(carmen_bag.SCAN_TOPIC, [])
        wait_for(node_subscribed, START_TIMEOUT, f"{node_name} to subscribe to {carmen_bag.SCAN_TOPIC}", alive)
        cpu0 = cpu_seconds(node.pid)
        duration = float(scans.stamps[-1] - scans.stamps[0])
        wall0 = time.monotonic()
        play = start("play", ["rosbag", "play", "-q", "--clock", "-r", str(rate), "--wait-for-subscribers", bag])
        timeout = TIMEOUT_FACTOR * duration / rate + START_TIMEOUT
        wait_for(lambda: play.poll() is not None, timeout, f"rosbag play to end ({duration:.0f} s of log at "
                 f"rate {rate})", alive)
        if play.returncode != 0:
            raise RuntimeError(f"rosbag play failed (exit status {play.returncode}):\n{tail(logs['play'])}")
        play_wall = time.monotonic() - wall0
        # the node may still work on queued scans: wait until it is idle
        idle_end = time.monotonic() + IDLE_TIMEOUT
        last = cpu_seconds(node.pid)
        while time.monotonic() < idle_end:
            time.sleep(IDLE_WINDOW)
            check_alive(alive, "it to be idle after the bag")
            now = cpu_seconds(node.pid)
            if now - last < IDLE_CPU:
                break
            last = now
        # its last map -> odom
        t_end = float(scans.stamps[-1])
        for k in range(1, int(round(CLOCK_TAIL / CLOCK_TAIL_STEP)) + 1):
            clock_pub.publish(Clock(clock=rospy.Time.from_sec(t_end + k * CLOCK_TAIL_STEP)))
            time.sleep(CLOCK_TAIL_STEP)
        time.sleep(0.5)   # the last broadcasts reach the recorder
        cpu = cpu_seconds(node.pid) - cpu0
        rss = peak_rss_mb(node.pid)
        with rec.lock:
            m2o = np.array(rec.m2o, float).reshape(-1, 4)
            map_msg, maps, refs = rec.map_msg, rec.maps, rec.references
        if slam == "karto" and node_cmd is None:   # after the CPU figure: saving is not mapping
            graph = final_graph(f"/{node_name}/serialize_map", os.path.join(out_dir, f"slam_bag_seed{seed}"), scans)
    finally:
        for p in reversed(procs):
            stop_process_tree(p, grace=10.0)
        roscore.stop(grace=10.0)
        try:
            import rospy
            rospy.signal_shutdown("bench_slam_bag: run over")
        except Exception:  # rospy never initialized
            pass
    m2o = m2o[np.argsort(m2o[:, 0], kind="stable")]
    ate, traj = online_eval.online_ate(scans.stamps, scans.odometry, scans.reference, m2o[:, 0], m2o[:, 1:])
    ate_final = None
    if slam == "karto":
        if graph is not None:
            updates = len(graph[0])
            ate_final = float(online_eval.metrics.ate_rmse(graph[0], scans.reference[graph[1]]))
        else:
            updates = online_eval.count_updates(m2o[:, 1:]) if maps else 0
        expected = online_eval.expected_updates(scans.odometry, *KARTO_GATE)
    else:
        if node_cmd is None:
            updates = online_eval.count_updates(m2o[:, 1:]) if maps else 0
        else:
            updates = node_log_updates(logs["node"])
        expected = online_eval.expected_updates(scans.odometry, params["linearUpdate"], params["angularUpdate"])
    result = dict(
        bag=bag, node=node_cmd or SLAMS[slam][0], slam=slam, seed=seed, rate=rate, scans=len(scans.stamps),
        log_s=duration, play_wall_s=play_wall,
        ate_online_m=ate, ate_final_m=ate_final,
        ate_odom_m=float(online_eval.metrics.ate_rmse(scans.odometry, scans.reference)),
        cpu_s=cpu, updates=updates, expected_updates=expected,
        cpu_ms_per_update=1000.0 * cpu / updates if updates else None,
        peak_rss_mb=rss, maps_received=maps, reference_poses_received=refs, map_to_odom_broadcasts=len(m2o),
        params=params, logs=logs)
    if map_msg is None:
        raise RuntimeError(f"{node_name} published no map; last lines of {logs['node']}:\n{tail(logs['node'])}")
    series = os.path.join(out_dir, f"slam_bag_seed{seed}.npz")
    np.savez_compressed(series, scan_stamps=scans.stamps, odometry=scans.odometry, reference=scans.reference,
                        online=traj, map_to_odom=m2o)
    result["series"] = series
    png = os.path.join(out_dir, f"slam_bag_seed{seed}.png")
    info = map_msg.info
    grid = (np.asarray(map_msg.data, np.int8), info.width, info.height, info.resolution,
            info.origin.position.x, info.origin.position.y)
    from bench_slam_carmen import write_png
    write_png(grid, traj, png)
    result["png"] = png
    return result


# ----------------------------------------------------------------- several seeds
def summarize(results):
    """Median and worst of the per-seed figures."""
    keys_high_bad = ("ate_online_m", "ate_odom_m", "cpu_s", "peak_rss_mb")
    med = {k: statistics.median(r[k] for r in results) for k in keys_high_bad}
    worst = {k: max(r[k] for r in results) for k in keys_high_bad}
    for k in ("cpu_ms_per_update", "updates", "ate_final_m"):   # None: not known (another node's)
        known = [r.get(k) for r in results if r.get(k) is not None]
        med[k] = statistics.median(known) if known else None
        worst[k] = (min if k == "updates" else max)(known) if known else None
    med["expected_updates"] = statistics.median(r["expected_updates"] for r in results)
    return med, worst


def known(value, spec):
    """value formatted with spec, or "n/a" (as wide) when it is None."""
    if value is not None:
        return format(value, spec)
    return "n/a".rjust(int(re.match(r"\d*", spec).group() or 0))


def make_bag(log, seed, tmp):
    """The path of the bag for this seed (made in tmp); a bag given as LOG is used as is."""
    from my_summit_mapping import carmen, carmen_bag
    if log.endswith(".bag"):
        return log
    path = os.path.join(tmp, f"carmen_seed{seed}.bag")
    carmen_bag.write_bag(carmen_bag.bag_scans(carmen.read_carmen(log), seed), path)
    return path


def slice_bag(bag, seconds, tmp):
    """A copy of `bag` with the messages up to `seconds` [s] after its first scan."""
    import rosbag
    from my_summit_mapping import carmen_bag
    out = os.path.join(tmp, os.path.basename(bag)[:-4] + f"_first{seconds:g}s.bag")
    end = None
    with rosbag.Bag(bag) as src, rosbag.Bag(out, "w") as dst:
        for topic, msg, t, conn in src.read_messages(return_connection_header=True):
            if end is None and topic == carmen_bag.SCAN_TOPIC:
                end = t.to_sec() + seconds
            if end is not None and t.to_sec() > end:
                break
            dst.write(topic, msg, t, connection_header=conn)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", help="CARMEN log (.log/.log.gz) or a bag from carmen_to_bag.py")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1], help="one run per seed")
    parser.add_argument("--rate", type=float, default=0.5, help="rosbag play rate (0.5: the standard evaluation)")
    parser.add_argument("--duration", type=float, help="only the first DURATION seconds of the log")
    parser.add_argument("--json", help="write the results as JSON to this path")
    parser.add_argument("--out", help="directory for the map PNGs and the logs (default output/slam_bag)")
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE", help="override a node parameter")
    parser.add_argument("--slam", choices=sorted(SLAMS), default="gmapping",
                        help="the node under test: slam_gmapping (default) or slam_karto")
    parser.add_argument("--node", metavar="EXECUTABLE",
                        help="run this executable with --slam's interface (e.g. the real gmapping's or slam_karto's) "
                             "instead of ours")
    parser.add_argument("--node-setup", metavar="SETUP_BASH",
                        help="source this file (e.g. a catkin devel/setup.bash) for --node's environment")
    parser.add_argument("--child-seed", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    out = args.out or os.path.join(WS, "output", "slam_bag")
    try:
        overrides = parse_set(args.set)
        if args.rate <= 0.0 or not math.isfinite(args.rate):
            raise ValueError(f"--rate must be a finite number > 0, got {args.rate}")
        if not os.path.exists(args.log):
            raise FileNotFoundError(f"{args.log}: no such file")
        check_node_args(args.node, args.node_setup)
    except (ValueError, OSError) as e:
        print(f"bench_slam_bag: error: {e}", file=sys.stderr)
        return 2
    os.makedirs(out, exist_ok=True)
    if args.child_seed is not None:   # one run, in its own process (rospy initializes once per process)
        try:
            result = run_once(args.log, args.child_seed, args.rate, overrides, out, args.node, args.node_setup,
                              args.slam)
        except (RuntimeError, ValueError, OSError) as e:
            print(f"bench_slam_bag: error: seed {args.child_seed}: {e}", flush=True)
            return 1
        print_result(result)
        return 0
    return run_seeds(args, overrides, out)


def run_seeds(args, overrides, out):
    results = []
    print(f"{os.path.basename(args.log)}, rosbag play rate {args.rate:g}, node {args.node or SLAMS[args.slam][0]}")
    print(f"{'seed':>4} {'ATE online':>10} {'ATE final':>9} {'ATE odom':>9} {'CPU s':>7} {'ms/update':>9} "
          f"{'updates':>11} {'RSS MB':>7} {'wall s':>7}", flush=True)
    with tempfile.TemporaryDirectory(prefix="slam_bag_") as tmp:
        for seed in args.seeds:
            try:
                bag = make_bag(args.log, seed, tmp)
                if args.duration:
                    bag = slice_bag(bag, args.duration, tmp)
            except (OSError, ValueError) as e:
                print(f"bench_slam_bag: error: {e}", file=sys.stderr)
                return 2
            cmd = [sys.executable, os.path.abspath(__file__), bag, "--child-seed", str(seed), "--rate", str(args.rate),
                   "--out", out, "--slam", args.slam] + (["--set"] + args.set if args.set else []) \
                + (["--node", os.path.abspath(args.node)] if args.node else []) \
                + (["--node-setup", os.path.abspath(args.node_setup)] if args.node_setup else [])
            r, failure = child_result(cmd)
            if r is None:
                print(f"bench_slam_bag: seed {seed} failed ({failure}", file=sys.stderr)
                return 1
            results.append(r)
            print(f"{seed:4d} {r['ate_online_m']:10.3f} {known(r.get('ate_final_m'), '9.3f')} {r['ate_odom_m']:9.3f} "
                  f"{r['cpu_s']:7.1f} "
                  f"{known(r['cpu_ms_per_update'], '9.1f')} {known(r['updates'], '5d')}/{r['expected_updates']:<5d} "
                  f"{r['peak_rss_mb']:7.0f} {r['play_wall_s']:7.0f}", flush=True)
    med, worst = summarize(results)
    print(f"median ATE online {med['ate_online_m']:.3f} m (worst {worst['ate_online_m']:.3f}), final "
          f"{known(med['ate_final_m'], '.3f')} m, odometry "
          f"{med['ate_odom_m']:.3f} m; CPU {med['cpu_s']:.1f} s, {known(med['cpu_ms_per_update'], '.1f')} ms per "
          f"update (worst {known(worst['cpu_ms_per_update'], '.1f')}); peak RSS {med['peak_rss_mb']:.0f} MB; maps in {out}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(log=os.path.abspath(args.log), node=args.node or SLAMS[args.slam][0], slam=args.slam,
                           rate=args.rate,
                           seeds=args.seeds, runs=results, median=med, worst=worst, duration=args.duration),
                      f, indent=2)
    return 0


if __name__ == "__main__":
    exit_on_sigterm()   # a kill stops the graphs this run started
    sys.exit(main())
