#!/usr/bin/python3
"""Benchmark of ekf_localization_node on the tour: raw skid odometry against the fused.

For each seed, the built-in world's tour (summit_xl_sim tour.launch: skid-steer odometry,
the BMI088 IMU, the simulator's odom tf off) is recorded once into a bag (/odom,
/imu/data, /tf_static, /base_pose_ground_truth; output/ekf_bags/seed<S>.bag, kept and
reused: --bags), then played (`rosbag play --clock -r RATE`) into an
ekf_localization_node loaded with config/ekf.yaml, on a private ROS master, while
`rosbag record` keeps its /odometry/filtered. So ours and another node (--node: the real
robot_localization's ekf_localization_node, --setup: the setup.bash its environment
needs) see the very same drive.

Per run, judged by ground truth (my_summit_localization.odom_error: truth taken relative
to the start pose, the odom frame's origin; no alignment), for the raw /odom and the
fused odometry, over the same span:
  heading error after the tour [deg], ATE [m], position error at the end [m]
and the node's CPU (utime + stime) per simulated second of the bag, its peak RSS
(VmHWM) [MB], messages on odometry/filtered and how many held NaN or inf.
Medians over the seeds go to the JSON (--json).

Usage: bench_ekf.py [--seeds 1 2 3 4 5] [--rate 1] [--speed 3] [--bags DIR] [--out DIR]
                    [--node EXECUTABLE [--setup SETUP_BASH]] [--config YAML] [--json PATH]
"""
import argparse
import json
import math
import os
import signal
import statistics
import subprocess
import sys
import time

import numpy as np
import yaml

from summit_nav_common.testing.roslaunch_session import (Roscore, Watched, check_alive, cpu_seconds, exit_on_sigterm,
                                                         peak_rss_mb, sourced_env, stop_process_tree, tail, wait_for)

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
WS = os.path.dirname(os.path.dirname(PKG))
OUT = os.path.join(WS, "output")
CONFIG = os.path.join(PKG, "config", "ekf.yaml")
OUR_NODE = os.path.join(PKG, "nodes", "ekf_localization_node")
NODE_NAME = "ekf_se"
RECORD_TOPICS = ("/odom", "/imu/data", "/tf_static", "/base_pose_ground_truth")
PLAY_TOPICS = ("/odom", "/imu/data", "/tf_static")
SENSOR_TOPICS = ("/odom", "/imu/data")
START_TIMEOUT = 60.0     # [s wall] a master, a node, a subscription
TOUR_TIMEOUT = 900.0     # [s wall] the tour's recording at SPEED on a busy machine
PLAY_TIMEOUT_FACTOR = 3.0   # the bag's wall length at RATE, times this, before giving up
TAIL_S = 1.0             # [s wall] after the bag, for the node's last outputs to reach the recorder


def _start(args, log, env):
    with open(log, "w") as f:
        return subprocess.Popen(args, stdout=f, stderr=subprocess.STDOUT, env=env, start_new_session=True)


def _stop_record(proc):
    """rosbag record ends cleanly on SIGINT (the bag closed, .active renamed)."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            pass
    stop_process_tree(proc, grace=5.0)


def record_tour(seed, speed, bag, logs_dir):
    """The tour with seed `seed` at `speed` x real time, recorded into `bag`."""
    logs = {k: os.path.join(logs_dir, f"record_seed{seed}_{k}.log") for k in ("roscore", "record", "launch")}
    tmp = bag[:-len(".bag")] + ".tmp.bag"
    with Roscore(log=logs["roscore"], timeout=START_TIMEOUT, caller="/bench_ekf") as core:
        core.master.setParam("/use_sim_time", True)   # bag times in simulated time
        env = core.env
        rec = _start(["rosbag", "record", "-O", tmp, *RECORD_TOPICS], logs["record"], env)
        launch = None
        try:
            wait_for(lambda: _subscribed(core.master, "/base_pose_ground_truth", "/record"), START_TIMEOUT,
                     "rosbag record to subscribe", [core, Watched.process("rosbag record", rec, logs["record"])])
            launch = _start(["roslaunch", "summit_xl_sim", "tour.launch", f"seed:={seed}", f"speed:={speed:g}",
                             "end_when_done:=true", "publish_odom_tf:=false"], logs["launch"], env)
            wait_for(lambda: launch.poll() is not None, TOUR_TIMEOUT, f"the tour (seed {seed}) to end",
                     [core, Watched.process("rosbag record", rec, logs["record"])])
        finally:
            _stop_record(rec)
            stop_process_tree(launch)
    if not os.path.exists(tmp):
        raise RuntimeError(f"rosbag record wrote no bag:\n{tail(logs['record'])}")
    os.replace(tmp, bag)


def _subscribed(master, topic, prefix):
    subs = dict((t, n) for t, n in master.getSystemState()[1])
    return any(n.startswith(prefix) for n in subs.get(topic, []))


def node_command(node):
    """The command of the node under test: ours with the ROS Python, or node."""
    if node is None:
        return [sys.executable, OUR_NODE, f"__name:={NODE_NAME}"]
    return [node, f"__name:={NODE_NAME}"]


def play_once(bag, seed, rate, config, out_dir, node=None, setup=None):
    """Play bag into the node (ours, or `node`); the fused track and the node's figures."""
    logs = {k: os.path.join(out_dir, f"play_seed{seed}_{k}.log") for k in ("roscore", "node", "record", "play")}
    out_bag = os.path.join(out_dir, f"fused_seed{seed}.bag")
    for p in (out_bag, out_bag + ".active"):
        if os.path.exists(p):
            os.remove(p)
    with open(config) as f:
        params = yaml.safe_load(f)
    with Roscore(log=logs["roscore"], timeout=START_TIMEOUT, caller="/bench_ekf") as core:
        master, env = core.master, core.env
        master.setParam("/use_sim_time", True)
        for k, v in params.items():
            master.setParam(f"/{NODE_NAME}/{k}", v)
        node_env = dict(sourced_env(setup, env, extend=True) if setup else env,
                        ROS_MASTER_URI=env["ROS_MASTER_URI"])
        procs = []
        try:
            proc = _start(node_command(node), logs["node"], node_env)
            procs.append(proc)
            rec = _start(["rosbag", "record", "-O", out_bag, "/odometry/filtered", "/diagnostics"], logs["record"], env)
            procs.append(rec)
            alive = [core, Watched.process("the EKF node", proc, logs["node"]),
                     Watched.process("rosbag record", rec, logs["record"])]
            for topic in SENSOR_TOPICS:
                wait_for(lambda t=topic: _subscribed(master, t, f"/{NODE_NAME}"), START_TIMEOUT,
                         f"the EKF node to subscribe to {topic}", alive)
            wait_for(lambda: _subscribed(master, "/odometry/filtered", "/record"), START_TIMEOUT,
                     "rosbag record to subscribe to /odometry/filtered", alive)
            duration = bag_duration(bag)
            cpu0 = cpu_seconds(proc.pid)
            wall0 = time.monotonic()
            play = _start(["rosbag", "play", "-q", "--clock", "-r", f"{rate:g}", bag, "--topics", *PLAY_TOPICS],
                          logs["play"], env)
            procs.append(play)
            wait_for(lambda: play.poll() is not None, PLAY_TIMEOUT_FACTOR * duration / rate + START_TIMEOUT,
                     f"rosbag play of {duration:.0f} s at rate {rate:g}", alive)
            if play.returncode != 0:
                raise RuntimeError(f"rosbag play failed (exit status {play.returncode}):\n{tail(logs['play'])}")
            play_wall = time.monotonic() - wall0
            time.sleep(TAIL_S)
            check_alive(alive, "the last outputs")
            cpu = cpu_seconds(proc.pid) - cpu0
            rss = peak_rss_mb(proc.pid)
            _stop_record(rec)
        finally:
            for p in reversed(procs):
                stop_process_tree(p, grace=10.0)
    return {"cpu_s": cpu, "sim_s": duration, "cpu_per_sim_s": cpu / duration, "peak_rss_mb": rss,
            "play_wall_s": play_wall, "fused_bag": out_bag}


def bag_duration(bag):
    import rosbag
    with rosbag.Bag(bag) as b:
        return b.get_end_time() - b.get_start_time()


def read_tracks(bag, topics):
    """{topic: (rows (t, x, y, yaw), messages with a non-finite field)} of nav_msgs/Odometry topics."""
    import rosbag
    out = {t: ([], 0) for t in topics}
    with rosbag.Bag(bag) as b:
        for topic, msg, _ in b.read_messages(topics=list(topics)):
            p, q = msg.pose.pose.position, msg.pose.pose.orientation
            values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w, *msg.pose.covariance, *msg.twist.covariance,
                      msg.twist.twist.linear.x, msg.twist.twist.angular.z]
            rows, bad = out[topic]
            if not all(math.isfinite(v) for v in values):
                out[topic] = (rows, bad + 1)
                continue
            yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
            rows.append((msg.header.stamp.to_sec(), p.x, p.y, yaw))
    return {t: (np.array(rows, dtype=np.float64).reshape(-1, 4), bad) for t, (rows, bad) in out.items()}


def filter_counts(fused_bag):
    """The node's last /diagnostics values whose key is a topic (ours: "received N,
    fused N, rejected N, dropped N") or "lagged measurements"; {} for a node that says no
    such thing."""
    import rosbag
    last = {}
    with rosbag.Bag(fused_bag) as b:
        for _, msg, _ in b.read_messages(topics=["/diagnostics"]):
            for st in msg.status:
                if st.name.endswith(": Filter"):
                    last = {kv.key: kv.value for kv in st.values
                            if kv.key.startswith("/") or kv.key == "lagged measurements"}
    return last


def judge(rec_bag, fused_bag):
    """Raw /odom and fused odometry/filtered against the truth over their common span."""
    from my_summit_localization.odom_error import odom_error
    rec = read_tracks(rec_bag, ("/odom", "/base_pose_ground_truth"))
    fused, bad = read_tracks(fused_bag, ("/odometry/filtered",))["/odometry/filtered"]
    raw, truth = rec["/odom"][0], rec["/base_pose_ground_truth"][0]
    if len(fused) == 0:
        raise RuntimeError(f"no odometry/filtered message in {fused_bag}")
    t_end = min(raw[-1, 0], fused[-1, 0])
    out = {"fused_messages": len(fused), "fused_not_finite": bad, "t_end": t_end,
           "filter_counts": filter_counts(fused_bag)}
    for name, track in (("raw", raw), ("fused", fused)):
        e = odom_error(track, truth, t_end=t_end)
        out[name] = {"heading_deg": math.degrees(e.final_heading), "ate_m": e.ate,
                     "final_position_m": e.final_position, "max_heading_deg": math.degrees(e.max_heading)}
    return out


def run(args):
    bags = args.bags or os.path.join(OUT, "ekf_bags")
    os.makedirs(bags, exist_ok=True)
    os.makedirs(args.out, exist_ok=True)
    runs = []
    print(f"ekf bench: node {args.node or 'ours'}, config {args.config}, rosbag play rate {args.rate:g}", flush=True)
    print(f"{'seed':>4} {'raw hdg':>8} {'fused':>7} {'raw ATE':>8} {'fused':>7} {'CPU/sim s':>9} {'RSS MB':>7}",
          flush=True)
    for seed in args.seeds:
        bag = os.path.join(bags, f"seed{seed}.bag")
        if not os.path.exists(bag):
            record_tour(seed, args.speed, bag, bags)
        r = play_once(bag, seed, args.rate, args.config, args.out, args.node, args.setup)
        r.update(judge(bag, r["fused_bag"]), seed=seed, bag=bag)
        runs.append(r)
        print(f"{seed:>4} {r['raw']['heading_deg']:8.2f} {r['fused']['heading_deg']:7.2f} "
              f"{r['raw']['ate_m']:8.3f} {r['fused']['ate_m']:7.3f} {r['cpu_per_sim_s']:9.4f} "
              f"{r['peak_rss_mb']:7.0f}", flush=True)
    med = lambda f: statistics.median(f(r) for r in runs)   # noqa: E731
    median = {"raw_heading_deg": med(lambda r: r["raw"]["heading_deg"]),
              "fused_heading_deg": med(lambda r: r["fused"]["heading_deg"]),
              "raw_ate_m": med(lambda r: r["raw"]["ate_m"]), "fused_ate_m": med(lambda r: r["fused"]["ate_m"]),
              "cpu_per_sim_s": med(lambda r: r["cpu_per_sim_s"]), "peak_rss_mb": med(lambda r: r["peak_rss_mb"])}
    print(f"median: heading after the tour raw {median['raw_heading_deg']:.2f} deg, fused "
          f"{median['fused_heading_deg']:.2f} deg; ATE raw {median['raw_ate_m']:.3f} m, fused "
          f"{median['fused_ate_m']:.3f} m; CPU {median['cpu_per_sim_s']:.4f} s per simulated s; peak RSS "
          f"{median['peak_rss_mb']:.0f} MB", flush=True)
    return {"node": args.node, "setup": args.setup, "config": os.path.relpath(args.config, WS), "rate": args.rate,
            "speed": args.speed, "seeds": list(args.seeds), "runs": runs, "median": median,
            "not_finite_total": sum(r["fused_not_finite"] for r in runs)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--rate", type=float, default=1.0, help="rosbag play rate")
    ap.add_argument("--speed", type=float, default=3.0, help="the tour's recording: simulated s per wall s")
    ap.add_argument("--bags", help="directory of the recorded tours (reused when there; default output/ekf_bags)")
    ap.add_argument("--out", default=os.path.join(OUT, "bench_ekf"), help="logs and fused bags")
    ap.add_argument("--node", metavar="EXECUTABLE", help="another ekf_localization_node (e.g. robot_localization's)")
    ap.add_argument("--setup", metavar="SETUP_BASH", help="--node: a setup.bash its environment needs (--extend)")
    ap.add_argument("--config", default=CONFIG, help="the EKF's YAML (robot_localization's format)")
    ap.add_argument("--json", help="write the result here")
    args = ap.parse_args()
    if args.setup and not args.node:
        ap.error("--setup needs --node")
    if args.node and not (os.path.isfile(args.node) and os.access(args.node, os.X_OK)):
        ap.error(f"--node {args.node}: not an executable file")
    if args.setup and not os.path.isfile(args.setup):
        ap.error(f"--setup {args.setup}: no such file")
    if not os.path.isfile(args.config):
        ap.error(f"--config {args.config}: no such file")
    args.config = os.path.abspath(args.config)
    exit_on_sigterm()
    res = run(args)
    if args.json:
        with open(args.json + ".tmp", "w") as f:
            json.dump(res, f, indent=2)
        os.replace(args.json + ".tmp", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
