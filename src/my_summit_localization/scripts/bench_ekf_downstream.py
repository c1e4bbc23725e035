#!/usr/bin/python3
"""Benchmark of amcl and slam_gmapping on the raw wheel odometry and on the EKF's.

Issue 41's downstream figures. On the built-in world's tour with the skid-steer odometry
(the simulator's default), for each seed and each odometry:
  raw    the simulator broadcasts odom -> base_footprint from its wheel odometry
  fused  the simulator leaves it to ekf_localization_node (config/ekf.yaml: the wheels'
         velocities and the IMU's yaw rate), as `ekf:=true` does in the course's launches
the same two runs are made, each on a private ROS master:
  amcl   tour.launch + amcl.launch [ekf:=true] on the committed map, from the known pose:
         every SAMPLE_S of the truth's stamps after SETTLE_S, the pose tf gives (map ->
         base_footprint, amcl's correction composed with the odometry, what move_base
         reads) against the ground truth taken into the map frame (the map's frame
         registered against the world, summit_nav_common.testing.ground_truth); all
         lookups at the end of the tour from a buffer holding the whole tour. Position
         and yaw error: median, 95th percentile, max, RMSE.
  slam   slam_gmapping on the tour (my_summit_mapping's bench_slam_sim.py, one run, its
         scoring: ATE against the truth, map precision / recall against the true walls
         the laser saw); `--ekf` runs it through ekf.launch mapping:=true.
Medians over the seeds of each figure go to the JSON (--json), raw and fused side by side;
each amcl run's samples (stamp, position and yaw error) to OUT/amcl_<odometry>_seed<S>_errors.csv.

Usage: bench_ekf_downstream.py [--seeds 1 2 3 4 5] [--parts amcl slam] [--odometry raw fused]
                               [--speed 2] [--out DIR] [--json PATH]
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time

import numpy as np

from summit_nav_common.testing import roslaunch_session
from summit_nav_common.testing.roslaunch_session import RoslaunchSession, wait_for, wait_for_sim_time_param

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
WS = os.path.dirname(os.path.dirname(PKG))
SLAM_BENCH = os.path.join(WS, "src", "my_summit_mapping", "scripts", "bench_slam_sim.py")
ODOMETRY = ("raw", "fused")
SETTLE_S = 5.0            # [s sim] errors counted after this (the amcl tracking rostest's)
SAMPLE_S = 0.1            # [s sim] between compared truth samples
TF_CACHE_S = 900.0        # [s sim] the tf buffer holds the whole tour (~190 s)
START_TIMEOUT = 120.0     # [s wall] for amcl's first pose
TOUR_TIMEOUT = 1200.0     # [s wall] for the tour on a busy machine
TAIL_S = 1.0              # [s sim] after the tour, for the last transforms

LAUNCH = """<launch>
  <include file="$(find summit_xl_sim)/launch/tour.launch">
    <arg name="speed" value="{speed}"/>
    <arg name="seed" value="{seed}"/>
    <arg name="publish_odom_tf" value="{raw}"/>
  </include>
  <include file="$(find my_summit_localization)/launch/amcl.launch">
    <arg name="ekf" value="{fused}"/>
  </include>
</launch>
"""


def error_stats(pos_err, yaw_err):
    """Median, 95th percentile, max and RMSE of position errors [m] and |yaw| errors [rad
    in, deg out]."""
    p, y = np.asarray(pos_err, float), np.degrees(np.abs(np.asarray(yaw_err, float)))
    out = {}
    for name, e, unit in (("pos", p, "m"), ("yaw", y, "deg")):
        out.update({f"{name}_median_{unit}": float(np.median(e)), f"{name}_p95_{unit}": float(np.percentile(e, 95)),
                    f"{name}_max_{unit}": float(np.max(e)), f"{name}_rmse_{unit}": float(np.sqrt(np.mean(e ** 2)))})
    return out


def map_in_world():
    """The committed map's frame in the built-in world (amcl.launch's defaults: my_map.yaml,
    spawn 2, 7, 0), registered once against the world."""
    from summit_nav_common.testing.ground_truth import register_map
    found = register_map(os.path.join(WS, "src", "my_summit_mapping", "maps", "my_map.yaml"),
                         os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml"), (2.0, 7.0, 0.0))
    return [float(v) for v in found]


def run_amcl(seed, odometry, speed, m_in_w, out):
    """One amcl run (see the module docstring); its figures as a dict."""
    import rospy
    import tf2_ros
    from nav_msgs.msg import Odometry
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from std_msgs.msg import Bool
    from summit_nav_common.geometry import pose_error, quaternion_to_yaw
    from summit_nav_common.testing.ground_truth import truth_in_map
    from summit_nav_common.testing.waits import Latest

    fused = odometry == "fused"
    launch = os.path.join(out, f"amcl_{odometry}_seed{seed}.launch")
    with open(launch, "w") as f:
        f.write(LAUNCH.format(speed=speed, seed=seed, raw=str(not fused).lower(), fused=str(fused).lower()))
    log = os.path.join(out, f"amcl_{odometry}_seed{seed}.log")
    load0 = os.getloadavg()[0]
    wall0 = time.monotonic()
    with RoslaunchSession([launch], log=log) as session:
        wait_for_sim_time_param(session)
        rospy.init_node("bench_ekf_downstream", anonymous=True, disable_signals=True)
        buf = tf2_ros.Buffer(rospy.Duration(TF_CACHE_S))
        tf2_ros.TransformListener(buf)
        truth = []    # every ground truth message's (stamp [s], x, y, yaw) in the map frame

        def on_truth(msg):
            truth.append((msg.header.stamp.to_sec(),) + tuple(truth_in_map(msg, m_in_w)))
        rospy.Subscriber("/base_pose_ground_truth", Odometry, on_truth, queue_size=None)
        done = Latest("/tour_driver/done", Bool)
        poses = Latest("/amcl_pose", PoseWithCovarianceStamped)
        wait_for(lambda: poses.msg is not None, START_TIMEOUT, "amcl's first pose", session)
        wait_for(lambda: done.msg is not None and done.msg.data, TOUR_TIMEOUT, "the tour's end", session, poll=0.5)
        t_done = rospy.Time.now().to_sec()
        wait_for(lambda: rospy.Time.now().to_sec() >= t_done + TAIL_S, 60.0, "the tail after the tour", session)
        pos_err, yaw_err, times, missed, next_t = [], [], [], 0, SETTLE_S
        for t, x, y, yaw in list(truth):
            if t < next_t or t > t_done:
                continue
            next_t = t + SAMPLE_S
            try:
                tr = buf.lookup_transform("map", "base_footprint", rospy.Time.from_sec(t))
            except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException):
                missed += 1
                continue
            est = (tr.transform.translation.x, tr.transform.translation.y, quaternion_to_yaw(tr.transform.rotation))
            e_pos, e_yaw = pose_error(est, (x, y, yaw))
            pos_err.append(e_pos)
            yaw_err.append(e_yaw)
            times.append(t)
        amcl_updates = poses.count
    if len(pos_err) < 100:
        raise RuntimeError(f"amcl {odometry} seed {seed}: only {len(pos_err)} samples ({missed} tf lookups "
                           f"failed); see {log}")
    errors = os.path.join(out, f"amcl_{odometry}_seed{seed}_errors.csv")   # where the errors arise
    np.savetxt(errors, np.column_stack([times, pos_err, np.degrees(yaw_err)]), fmt="%.4f",
               header="truth stamp [s], position error [m], |yaw error| [deg]")
    res = dict(seed=seed, odometry=odometry, samples=len(pos_err), missed_lookups=missed, tour_sim_s=t_done,
               amcl_updates=amcl_updates, wall_s=round(time.monotonic() - wall0, 1),
               load_average=[round(load0, 2), round(os.getloadavg()[0], 2)], log=log, errors=errors)
    res.update(error_stats(pos_err, yaw_err))
    return res


def run_slam(seed, odometry, speed, out):
    """One slam_gmapping run by bench_slam_sim.py (its scoring); its figures as a dict."""
    folder = os.path.join(out, f"slam_{odometry}_seed{seed}")
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "result.json")
    cmd = [sys.executable, SLAM_BENCH, "--runs", "1", "--speed", str(speed), "--out", folder, "--json", path,
           f"--launch-arg=seed:={seed}"] + (["--ekf"] if odometry == "fused" else [])
    load0 = os.getloadavg()[0]
    if subprocess.run(cmd).returncode != 0:
        raise RuntimeError(f"slam {odometry} seed {seed}: {' '.join(cmd)} failed (logs in {folder})")
    with open(path) as f:
        r = json.load(f)["runs"][0]
    keep = ("ate_m", "precision", "recall", "cpu_per_sim_s", "sim_s", "processed_scans", "png", "log")
    return dict(seed=seed, odometry=odometry, load_average=[round(load0, 2), round(os.getloadavg()[0], 2)],
                **{k: r[k] for k in keep if k in r})


AMCL_KEYS = ("pos_median_m", "pos_p95_m", "pos_max_m", "pos_rmse_m", "yaw_median_deg", "yaw_p95_deg", "yaw_max_deg",
             "yaw_rmse_deg")
SLAM_KEYS = ("ate_m", "precision", "recall")


def medians(runs, keys):
    """{odometry: {key: median over its runs}}."""
    out = {}
    for odo in ODOMETRY:
        mine = [r for r in runs if r["odometry"] == odo]
        if mine:
            out[odo] = {k: statistics.median(r[k] for r in mine) for k in keys}
            out[odo]["runs"] = len(mine)
    return out


def child(args):
    """One run in this process (rospy joins one master per process)."""
    roslaunch_session.print_result(run_amcl(args.seed, args.run_odometry, args.speed, tuple(args.map_in_world),
                                            args.out))
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5], help="the simulator's noise seeds")
    ap.add_argument("--parts", nargs="+", choices=("amcl", "slam"), default=["amcl", "slam"])
    ap.add_argument("--odometry", nargs="+", choices=ODOMETRY, default=list(ODOMETRY))
    ap.add_argument("--speed", type=float, default=2.0, help="simulated seconds per wall second")
    ap.add_argument("--out", default=os.path.join(WS, "output", "bench_ekf_downstream"),
                    help="logs, launch files, maps' pictures")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--run-odometry", choices=ODOMETRY, help=argparse.SUPPRESS)   # a child's run
    ap.add_argument("--seed", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--map-in-world", type=float, nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    roslaunch_session.exit_on_sigterm()   # `kill PID` stops the runs' graphs too
    os.makedirs(args.out, exist_ok=True)
    if args.run_odometry:
        return child(args)
    m_in_w = map_in_world() if "amcl" in args.parts else None
    amcl_runs, slam_runs = [], []
    for seed in args.seeds:
        for odo in args.odometry:
            if "amcl" in args.parts:
                r, why = roslaunch_session.child_result(
                    [sys.executable, os.path.abspath(__file__), "--run-odometry", odo, "--seed", str(seed),
                     "--speed", str(args.speed), "--out", args.out, "--map-in-world", *map(repr, m_in_w)])
                if r is None:
                    raise RuntimeError(f"amcl {odo} seed {seed}: {why}")
                amcl_runs.append(r)
                print(f"amcl {odo:5s} seed {seed}: position median {r['pos_median_m']:.3f} m, max "
                      f"{r['pos_max_m']:.3f} m; yaw median {r['yaw_median_deg']:.2f} deg, max {r['yaw_max_deg']:.2f} "
                      f"deg ({r['samples']} samples, {r['wall_s']:.0f} s wall, load {r['load_average']})", flush=True)
            if "slam" in args.parts:
                r = run_slam(seed, odo, args.speed, args.out)
                slam_runs.append(r)
                print(f"slam {odo:5s} seed {seed}: ATE {r['ate_m']:.3f} m, precision {r['precision']:.3f}, recall "
                      f"{r['recall']:.3f} (load {r['load_average']})", flush=True)
    result = dict(seeds=args.seeds, speed=args.speed, map_in_world=m_in_w, amcl_runs=amcl_runs, slam_runs=slam_runs,
                  amcl=medians(amcl_runs, AMCL_KEYS), slam=medians(slam_runs, SLAM_KEYS))
    for part in ("amcl", "slam"):
        for odo, med in result[part].items():
            print(f"{part} {odo} medians over {med['runs']} seeds: "
                  + ", ".join(f"{k} {v:.3f}" for k, v in med.items() if k != "runs"))
    if args.json:
        tmp = args.json + ".tmp"
        with open(tmp, "w") as f:
            json.dump(result, f, indent=1)
        os.replace(tmp, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
