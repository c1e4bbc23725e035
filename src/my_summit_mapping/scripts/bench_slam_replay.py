#!/usr/bin/python3
"""The filter's spread over seeds on a CARMEN log: ours and the real gmapping's, both seeded.

A live run of the real slam_gmapping cannot be repeated (its filter is seeded from the
clock), so a handful of live runs says little about a filter whose result on one bag
spreads over a factor of ten between seeds. Its package has a seeded offline player,
`slam_gmapping_replay --bag_filename BAG --seed S`, that feeds a bag's /tf and /scan
through the same SlamGMapping code as the live node. This script runs, for each seed S:
  - that player (given with --replay, in the environment --setup leaves) on the bag of
    bench_slam_bag.py for S (odometry drift seed S + carmen_bag.ODOM_SEED_OFFSET; the mount
    base_link -> base_laser also in /tf, which is all the player reads), with
    bench_slam_bag's node parameters, filter seed S, its ROS_DEBUG lines switched on;
    the best particle's pose after each update ("new best pose", laser frame; "update
    frame N" names the scan) gives the online estimate, scored as bench_slam_bag scores a
    live run (online aligned ATE over every scan, my_summit_mapping.online_eval);
  - our filter on the same scans with filter seed S (slam_bag_offline.replay: what our live
    node does with that bag and seed, to the millimetre).
Reported per seed and as median / worst: online ATE of both, CPU per update of both (the
real one: the whole player process, its map updates every map_update_interval included;
ours: the filter alone). The real filter's result depends on the map bounds (xmin ... ymax,
here around the trajectory as in bench_slam_bag) through a bug of its free-cell check;
ours does not (docs/slam.md); `--set xmin=-100 ymin=-100 xmax=100 ymax=100` runs it with
the node's defaults.

Usage: bench_slam_replay.py LOG --replay EXE [--setup SETUP_BASH] [--seeds 1 2 ...]
                            [--json PATH] [--set name=value ...]
  e.g. bench_slam_replay.py data/carmen/aces-corrected.log.gz --seeds 1 2 3 4 5 6 7 8 9 10 \\
           --replay /tmp/peers_ws/devel/lib/gmapping/slam_gmapping_replay --setup /tmp/peers_ws/devel/setup.bash
"""
import argparse
import json
import math
import os
import re
import resource
import statistics
import subprocess
import sys

import numpy as np

from bench_slam_bag import NODE_NAME, node_params, parse_set
from my_summit_mapping import carmen, carmen_bag, metrics, online_eval
from summit_nav_common.testing.roslaunch_session import Roscore, sourced_env
from summit_nav_common.geometry import compose, inverse

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.abspath(os.path.join(HERE, "..", "..", ".."))

# gmapping's ROS_DEBUG lines (package "gmapping" logs as ros.gmapping) and GridSlamProcessor's
# update line, the only outputs of the player that carry the estimate.
ROSCONSOLE_CONFIG = "log4j.logger.ros=INFO\nlog4j.logger.ros.gmapping=DEBUG\n"
UPDATE_FRAME = re.compile(r"update frame (\d+)")
BEST_POSE = re.compile(r"new best pose: (-?[\d.]+) (-?[\d.]+) (-?[\d.]+)")
ANSI = re.compile(r"\x1b\[[0-9;]*m")
START_TIMEOUT = 60.0       # [s wall] for roscore to answer
RUN_TIMEOUT = 3600.0       # [s wall] for one player run


def parse_player_log(text):
    """(scan indices (U,), best poses (U, 3) [m, m, rad]) of the updates in a player's log:
    each "new best pose" belongs to the "update frame N" before it. ValueError when a pose
    has no frame before it or there are none."""
    frames, poses = [], []
    frame = None
    for line in ANSI.sub("", text).splitlines():
        m = UPDATE_FRAME.search(line)
        if m:
            frame = int(m.group(1))
            continue
        m = BEST_POSE.search(line)
        if m:
            if frame is None:
                raise ValueError("a 'new best pose' line before any 'update frame' line")
            frames.append(frame)
            poses.append([float(v) for v in m.groups()])
            frame = None
    if not poses:
        raise ValueError("no 'new best pose' lines (is the player's debug output on?)")
    return np.array(frames, np.intp), np.array(poses, float)


def online_from_updates(frames, best_laser, odom_base, laser_yaw):
    """Online estimate (K, 3) of the base at every scan, scored as a live run's
    (online_eval.online_trajectory, with each scan's index as its stamp): map -> odom of
    each update (best pose * odometry pose at that update^-1, both of the laser frame the
    node tracks: base turned by laser_yaw [rad]) in effect from its scan until the next
    update, composed with the scan's odometry; the identity before the first update."""
    odom = np.asarray(odom_base, float)
    m2o = compose(best_laser, inverse(compose(odom[frames], np.array([0.0, 0.0, laser_yaw]))))
    return online_eval.online_trajectory(np.arange(len(odom)), odom, frames, m2o)


def centered_laser_yaw(scans):
    """slam_gmapping tracks a laser frame turned to the middle of the scan's angles."""
    n = scans.ranges.shape[1]
    return 0.5 * (2.0 * scans.angle_min + (n - 1) * scans.angle_increment)


def run_player(exe, setup, bag, seed, params, log_path):
    """One seeded run of the real player on `bag`; (its log text, CPU seconds)."""
    with Roscore(caller="/bench_slam_replay", timeout=START_TIMEOUT) as core:
        for key, value in params.items():
            core.master.setParam(f"/{NODE_NAME}/{key}", value)
        conf = os.path.join(os.path.dirname(log_path), "rosconsole.conf")
        with open(conf, "w") as f:
            f.write(ROSCONSOLE_CONFIG)
        child_env = dict(sourced_env(setup, core.env) if setup else core.env,
                         ROS_MASTER_URI=core.env["ROS_MASTER_URI"],
                         ROSCONSOLE_CONFIG_FILE=conf, ROSCONSOLE_FORMAT="${message}")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        with open(log_path, "w") as log:
            done = subprocess.run([exe, "--bag_filename", bag, "--seed", str(seed), "--on_done", "true"],
                                  stdout=log, stderr=subprocess.STDOUT, env=child_env, timeout=RUN_TIMEOUT)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if done.returncode != 0:
            raise RuntimeError(f"{exe} ended with exit status {done.returncode}; see {log_path}")
    with open(log_path, errors="replace") as f:
        text = f.read()
    return text, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run_seed(log, seed, exe, setup, overrides, out_dir):
    """Both filters on the bag of `seed`; a dict of their figures."""
    import slam_bag_offline
    scans = carmen_bag.bag_scans(log, seed)
    params = node_params(scans, overrides)
    bag = os.path.join(out_dir, f"replay_seed{seed}.bag")
    carmen_bag.write_bag(scans, bag, mount_in_tf=True)
    try:
        text, cpu = run_player(exe, setup, bag, seed, params, os.path.join(out_dir, f"replay_seed{seed}.log"))
    finally:
        os.unlink(bag)
    received = carmen_bag.as_received(scans)
    frames, best = parse_player_log(text)
    if frames.max() >= len(received.stamps) or np.any(np.diff(frames) <= 0):
        raise ValueError(f"seed {seed}: the player's update frames do not name the bag's scans in order")
    online = online_from_updates(frames, best, received.odometry, centered_laser_yaw(received))
    ours, _ = slam_bag_offline.replay(received, seed, overrides)
    return {"seed": seed, "scans": len(received.stamps),
            "real": {"ate_online_m": metrics.ate_rmse(online, received.reference), "updates": len(frames),
                     "cpu_s": cpu, "cpu_ms_per_update": 1000.0 * cpu / len(frames),
                     "resamples": text.count("*RESAMPLE*")},
            "ours": {k: ours[k] for k in ("ate_online_m", "updates", "cpu_s", "cpu_ms_per_update", "resamples")},
            "ate_odom_m": ours["ate_odom_m"]}


def summary(runs, who):
    ates = [r[who]["ate_online_m"] for r in runs]
    return {"median_ate_online_m": statistics.median(ates), "worst_ate_online_m": max(ates),
            "best_ate_online_m": min(ates),
            "median_cpu_ms_per_update": statistics.median(r[who]["cpu_ms_per_update"] for r in runs)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("log", help="CARMEN log (.log / .log.gz)")
    ap.add_argument("--replay", required=True, metavar="EXE",
                    help="the real gmapping's slam_gmapping_replay (built outside the project)")
    ap.add_argument("--setup", metavar="SETUP_BASH", help="source this file for --replay's environment")
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 11)))
    ap.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE", help="override a node parameter")
    ap.add_argument("--json", help="write the results as JSON to this path")
    ap.add_argument("--out", default=os.path.join(WS, "output", "slam_replay"), help="directory for the player logs")
    args = ap.parse_args(argv)
    try:
        if not (os.path.isfile(args.replay) and os.access(args.replay, os.X_OK)):
            raise ValueError(f"--replay {args.replay}: not an executable file")
        if args.setup is not None and not os.path.isfile(args.setup):
            raise ValueError(f"--setup {args.setup}: no such file")
        overrides = parse_set(args.set)
        log = carmen.read_carmen(args.log)
    except (OSError, ValueError) as e:
        print(f"bench_slam_replay: error: {e}", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    runs = []
    print(f"{os.path.basename(args.log)}: online aligned ATE [m] and CPU per update [ms], real gmapping's "
          f"{os.path.basename(args.replay)} / ours, filter seed = drift seed")
    print(f"{'seed':>4} {'real ATE':>9} {'ours ATE':>9} {'real ms':>8} {'ours ms':>8} {'updates':>9} "
          f"{'resamples':>9} {'odom ATE':>9}")
    for seed in args.seeds:
        try:
            r = run_seed(log, seed, args.replay, args.setup, overrides, args.out)
        except (OSError, ValueError, RuntimeError, subprocess.TimeoutExpired) as e:
            print(f"bench_slam_replay: error: seed {seed}: {e}", file=sys.stderr)
            return 1
        runs.append(r)
        print(f"{seed:4d} {r['real']['ate_online_m']:9.3f} {r['ours']['ate_online_m']:9.3f} "
              f"{r['real']['cpu_ms_per_update']:8.0f} {r['ours']['cpu_ms_per_update']:8.0f} "
              f"{r['real']['updates']:4d}/{r['ours']['updates']:<4d} "
              f"{r['real']['resamples']:4d}/{r['ours']['resamples']:<4d} {r['ate_odom_m']:9.3f}", flush=True)
    result = {"log": os.path.abspath(args.log), "replay": args.replay, "overrides": overrides, "runs": runs,
              "real": summary(runs, "real"), "ours": summary(runs, "ours")}
    for who in ("real", "ours"):
        s = result[who]
        print(f"{who}: online ATE median {s['median_ate_online_m']:.3f} m, worst {s['worst_ate_online_m']:.3f}, "
              f"best {s['best_ate_online_m']:.3f}; CPU per update median {s['median_cpu_ms_per_update']:.0f} ms")
    if args.json:
        tmp = args.json + ".tmp"
        with open(tmp, "w") as f:
            json.dump(result, f, indent=2)
        os.replace(tmp, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
