#!/usr/bin/python3
"""Benchmark of the live amcl node: CPU per simulated second on the simulator's tour.

Each run: `tour.launch` (simulator + tour driver, the built-in world) and `amcl.launch`
(map_server with my_map + amcl with config/amcl_params.yaml: 5000 max particles,
laser_max_beams 60, scans at 40 Hz) on a private ROS master. From simulated time --start
(or amcl's first pose, if later), a window of --sim-time simulated seconds is measured:
  cpu_per_sim_s   amcl's CPU (utime + stime of /proc/<pid>/stat) / simulated time (/clock)
  peak_rss_mb     amcl's VmHWM at the end [MB]
  scans, updates  scans published on the laser topic and amcl_pose messages (one per
                  filter update) in the window; scans - updates were only gated
  position_rmse_m, yaw_rmse_deg  amcl_pose against the simulator's ground truth
                  (/base_pose_ground_truth, taken into the map frame: the map's origin is
                  the spawn pose, amcl.launch's map_in_world_*) - a sanity check that a
                  faster node still localizes
  clouds          particle clouds received (only with --cloud: a subscriber as rviz)
  threads         CPU seconds of each of amcl's threads in the window (with --profile:
                  named by the topic whose receive loop it runs)
With --profile DIR, amcl runs under summit_nav_common.testing.profile_node (cProfile in every receive
thread, CPU clock) and DIR/amcl_run<i>.pstats holds the profile; the top functions by
cumulative and by own time are printed, and the shares of the profiled CPU of each
stage (PROFILE_STAGES: filter update, pose estimate, publishing, the rest of the scan
handling, reading messages, other callbacks) go to the JSON as profile_shares. The profiler slows the node: the CPU figures of
a profiled run are not the benchmark's.

The real C++ amcl with the same parameters on the same tour: 0.087 CPU s per simulated s
(target for ours: <= 0.12).

Usage: bench_amcl_node.py [--runs 3] [--sim-time 60] [--start 10] [--speed 1] [--json PATH]
                          [--cloud] [--profile DIR] [--launch-arg name:=value ...]
"""
import argparse
import json
import math
import os
import statistics
import sys
import threading
import time

import numpy as np

from summit_nav_common.testing import profile_node, roslaunch_session
from summit_nav_common.testing.roslaunch_session import cpu_seconds, find_node_pid, peak_rss_mb, thread_cpu


TARGET_CPU_PER_SIM_S = 0.12   # [CPU s / simulated s]; the real amcl: 0.087
REAL_AMCL_CPU_PER_SIM_S = 0.087
SCAN_TOPIC = "/hokuyo_base/scan"
MAP_IN_WORLD = (2.0, 7.0, 0.0)  # amcl.launch's map_in_world_* (the spawn pose of my_map)
SETTLE = 5.0                    # [s sim] errors counted after this long in the window
START_TIMEOUT = 120.0           # [s wall] for amcl's first pose

LAUNCH = """<launch>
  <include file="$(find summit_xl_sim)/launch/tour.launch">
    <arg name="speed" value="{speed}"/>
  </include>
  <include file="$(find my_summit_localization)/launch/amcl.launch">
    <arg name="launch_prefix" value="{prefix}"/>
  </include>
</launch>
"""


class Recorder:
    """amcl_pose, ground truth and the number of scans, from the topics."""

    def __init__(self, cloud=False):
        import rospy
        from geometry_msgs.msg import PoseWithCovarianceStamped
        from nav_msgs.msg import Odometry
        self.lock = threading.Lock()
        self.poses = []    # (t, x, y, yaw) map frame
        self.truth = []    # (t, x, y, yaw) map frame
        self.scan_stamps = []
        self.subs = [
            rospy.Subscriber("/amcl_pose", PoseWithCovarianceStamped, self._on_pose, queue_size=50),
            rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on_truth, queue_size=200),
            rospy.Subscriber(SCAN_TOPIC, rospy.AnyMsg, self._on_scan, queue_size=200)]
        self.clouds = 0
        if cloud:  # as rviz does: amcl then builds and sends the cloud
            self.subs.append(rospy.Subscriber("/particlecloud", rospy.AnyMsg, self._on_cloud, queue_size=5))

    def _on_cloud(self, _msg):
        self.clouds += 1

    @staticmethod
    def _pose(msg_pose):
        p, q = msg_pose.position, msg_pose.orientation
        return p.x, p.y, math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))

    def _on_pose(self, msg):
        with self.lock:
            self.poses.append((msg.header.stamp.to_sec(),) + self._pose(msg.pose.pose))

    def _on_truth(self, msg):
        x, y, yaw = self._pose(msg.pose.pose)
        ox, oy, oyaw = MAP_IN_WORLD
        c, s = math.cos(oyaw), math.sin(oyaw)
        dx, dy = x - ox, y - oy
        with self.lock:
            self.truth.append((msg.header.stamp.to_sec(), c * dx + s * dy, -s * dx + c * dy, yaw - oyaw))

    def _on_scan(self, _msg):
        import rospy
        with self.lock:
            self.scan_stamps.append(rospy.Time.now().to_sec())

    def counts(self, t0, t1):
        with self.lock:
            scans = sum(t0 < t <= t1 for t in self.scan_stamps)
            updates = sum(t0 < p[0] <= t1 for p in self.poses)
        return scans, updates

    def errors(self, t0, t1):
        """(position RMSE [m], yaw RMSE [deg], samples) of amcl_pose against the truth."""
        with self.lock:
            poses = np.array([p for p in self.poses if t0 + SETTLE < p[0] <= t1])
            truth = np.array(sorted(self.truth))
        if len(poses) == 0 or len(truth) < 2:
            return float("nan"), float("nan"), 0
        tx = np.interp(poses[:, 0], truth[:, 0], truth[:, 1])
        ty = np.interp(poses[:, 0], truth[:, 0], truth[:, 2])
        tyaw = np.interp(poses[:, 0], truth[:, 0], np.unwrap(truth[:, 3]))
        dpos = np.hypot(poses[:, 1] - tx, poses[:, 2] - ty)
        dyaw = np.angle(np.exp(1j * (poses[:, 3] - tyaw)))
        return (float(np.sqrt(np.mean(dpos ** 2))), float(np.degrees(np.sqrt(np.mean(dyaw ** 2)))),
                int(len(poses)))


def run_once(index, args, tmp):
    import rospy
    from summit_nav_common.testing.roslaunch_session import RoslaunchSession, wait_for, wait_for_sim_time_param
    prefix = ""
    out_prefix = None
    if args.profile:
        out_prefix = os.path.join(os.path.abspath(args.profile), f"amcl_run{index}")
        prefix = profile_node.launch_prefix(out_prefix)
    launch_path = os.path.join(tmp, f"bench_amcl_node_{index}.launch")
    with open(launch_path, "w") as f:
        f.write(LAUNCH.format(speed=args.speed, prefix=prefix))
    log = os.path.join(tmp, f"bench_amcl_node_run{index}.log")
    with RoslaunchSession([launch_path] + args.launch_arg, log=log) as session:
        wait_for_sim_time_param(session)
        rospy.init_node("bench_amcl_node", anonymous=True, disable_signals=True)
        rec = Recorder(cloud=args.cloud)
        wait_for(lambda: rec.poses, START_TIMEOUT, "amcl's first pose", session)
        # The window starts at a fixed simulated time, so every run measures the same
        # stretch of the tour whenever amcl came up.
        wait_for(lambda: rospy.Time.now().to_sec() >= args.start, START_TIMEOUT,
                 f"simulated time {args.start} s", session)
        pid = find_node_pid(session.proc.pid, "amcl")
        if pid is None:
            raise RuntimeError(f"amcl's process not found; see {log}")
        load0 = os.getloadavg()
        sim0, cpu0, thr0 = rospy.Time.now().to_sec(), cpu_seconds(pid), thread_cpu(pid)
        wall0 = time.monotonic()
        wait_for(lambda: rospy.Time.now().to_sec() >= sim0 + args.sim_time,
                 args.sim_time / max(args.speed, 0.05) * 4 + 60, f"{args.sim_time} s of simulated time",
                 session)
        sim1, cpu1, thr1 = rospy.Time.now().to_sec(), cpu_seconds(pid), thread_cpu(pid)
        wall1 = time.monotonic()
        rss = peak_rss_mb(pid)
        load1 = os.getloadavg()
        time.sleep(0.5)  # the last amcl_pose of the window
        scans, updates = rec.counts(sim0, sim1)
        clouds = rec.clouds
        pos_rmse, yaw_rmse, samples = rec.errors(sim0, sim1)
        for s in rec.subs:
            s.unregister()
    threads = {tid: thr1[tid] - thr0.get(tid, 0.0) for tid in thr1}
    names = {}
    if out_prefix and os.path.exists(out_prefix + ".threads.json"):
        with open(out_prefix + ".threads.json") as f:
            names = {int(k): v for k, v in json.load(f)["threads"].items()}
    named = {}
    for tid, cpu in sorted(threads.items(), key=lambda kv: -kv[1]):
        key = names.get(tid, "main" if tid == pid else f"tid {tid}")
        named[key] = named.get(key, 0.0) + cpu
    sim_s = sim1 - sim0
    return dict(run=index, sim_s=sim_s, wall_s=wall1 - wall0, cpu_s=cpu1 - cpu0,
                cpu_per_sim_s=(cpu1 - cpu0) / sim_s, peak_rss_mb=rss, scans=scans, updates=updates, clouds=clouds,
                scans_per_sim_s=scans / sim_s, updates_per_sim_s=updates / sim_s,
                position_rmse_m=pos_rmse, yaw_rmse_deg=yaw_rmse, error_samples=samples,
                threads={k: round(v, 3) for k, v in named.items() if v > 0.0},
                load_average=[round(x, 2) for x in load0 + load1], profile=out_prefix, log=log)


# Where the time goes: stage -> functions whose cumulative CPU it is, from the profile
# (file suffix, function name); later stages are subtracted from the ones that contain them.
PROFILE_STAGES = (
    ("filter update (motion, laser model, resampling)", [("particle_filter.py", "update")]),
    ("pose estimate (clusters, covariance)", [("particle_filter.py", "estimate")]),
    ("publishing (amcl_pose, tf)", [("rospy/topics.py", "publish")]),
    ("rest of the scan handling (tf wait, gating, conversion)",
     [("nodes/amcl", "on_scan"), ("tf_message_filter.py", "tf_arrived")]),
    ("reading and deserializing messages (all topics)", [("tcpros_base.py", "receive_once")]),
    ("/clock, tf listener and other callbacks", [("rospy/topics.py", "_invoke_callback")]),
)


# the scan handling contains the update, estimate and publishing; the callbacks contain it
PROFILE_CONTAINS = {3: [0, 1, 2], 5: [3]}


def profile_summary(path):
    """{stage: share of the profiled CPU} of a profile_node.py profile (PROFILE_STAGES)."""
    return profile_node.stage_shares(path, PROFILE_STAGES, PROFILE_CONTAINS)


def child(args):
    return profile_node.child_run(run_once, args, "bench_amcl_node_", profile_summary, 25)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--sim-time", type=float, default=60.0, help="measured window [s simulated]")
    ap.add_argument("--start", type=float, default=10.0,
                    help="simulated time the window starts [s] (or amcl's first pose, if later)")
    ap.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall second")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--profile", metavar="DIR", help="run amcl under summit_nav_common.testing.profile_node, profiles in DIR")
    ap.add_argument("--cloud", action="store_true",
                    help="subscribe to particlecloud, as rviz does (amcl builds it at gui_publish_rate)")
    ap.add_argument("--launch-arg", action="append", default=[], help="extra name:=value for the launch")
    ap.add_argument("--run-index", type=int, help=argparse.SUPPRESS)  # one run, in a child process
    args = ap.parse_args()
    roslaunch_session.exit_on_sigterm()   # `kill PID` stops the runs' graphs too
    if args.profile:
        os.makedirs(args.profile, exist_ok=True)
    if args.run_index is not None:
        return child(args)
    runs = []
    for i in range(args.runs):
        cmd = [sys.executable, os.path.abspath(__file__), "--run-index", str(i), "--sim-time", str(args.sim_time),
               "--start", str(args.start), "--speed", str(args.speed)]
        cmd += (["--cloud"] if args.cloud else []) + (["--profile", args.profile] if args.profile else [])
        cmd += [a for la in args.launch_arg for a in ("--launch-arg", la)]
        r = profile_node.run_child(cmd, i)
        runs.append(r)
        print(f"run {i}: {r['cpu_per_sim_s']:.3f} CPU s per simulated s ({r['cpu_s']:.1f} s over "
              f"{r['sim_s']:.1f} s simulated, {r['wall_s']:.1f} s wall); peak RSS {r['peak_rss_mb']:.0f} MB; "
              f"{r['scans']} scans, {r['updates']} filter updates; amcl_pose RMSE "
              f"{r['position_rmse_m']:.3f} m / {r['yaw_rmse_deg']:.2f} deg; load {r['load_average']}",
              flush=True)
        print("   threads (CPU s): " + ", ".join(f"{k} {v:.2f}" for k, v in r["threads"].items()), flush=True)
        if "profile_shares" in r:
            print("   profile (share of the profiled CPU): " +
                  ", ".join(f"{k} {v:.0%}" for k, v in r["profile_shares"].items()), flush=True)
    keys = ("cpu_per_sim_s", "peak_rss_mb", "scans_per_sim_s", "updates_per_sim_s", "position_rmse_m",
            "yaw_rmse_deg")
    median = {k: statistics.median(r[k] for r in runs) for k in keys}
    result = dict(runs=runs, median=median, speed=args.speed, sim_time=args.sim_time, start=args.start,
                  target_cpu_per_sim_s=TARGET_CPU_PER_SIM_S, real_amcl_cpu_per_sim_s=REAL_AMCL_CPU_PER_SIM_S,
                  profiled=bool(args.profile), cloud_subscribed=args.cloud)
    if args.profile and "profile_shares" in runs[0]:
        result["profile_shares"] = runs[0]["profile_shares"]
    print(f"median of {len(runs)}: {median['cpu_per_sim_s']:.3f} CPU s per simulated s (target <= "
          f"{TARGET_CPU_PER_SIM_S}; real amcl {REAL_AMCL_CPU_PER_SIM_S}); peak RSS {median['peak_rss_mb']:.0f} MB; "
          f"{median['scans_per_sim_s']:.1f} scans/s, {median['updates_per_sim_s']:.2f} updates/s; amcl_pose RMSE "
          f"{median['position_rmse_m']:.3f} m / {median['yaw_rmse_deg']:.2f} deg")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
