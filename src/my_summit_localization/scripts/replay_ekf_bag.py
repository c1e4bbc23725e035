#!/usr/bin/python3
"""Replay a recorded tour through the EKF's core offline (no ROS master, no timing noise).

Reads a bag that bench_ekf.py recorded (/odom, /imu/data, /tf_static,
/base_pose_ground_truth), turns each sensor message into measurements as
ekf_localization_node does (ekf_sensors; sensor frames through /tf_static), and runs
ekf_runner.EkfRunner's cycle at `frequency` in simulated time. Each message reaches the
filter either at the time the recorder received it (--arrival bag: the delays the live
node sees when the bag is played, without the machine's) or in stamp order (--arrival
stamp: no message lagged). The states the cycle would publish are judged against the
truth as bench_ekf.py judges them (my_summit_localization.odom_error, no alignment).

It is deterministic and takes a few CPU seconds a tour, so it separates what the filter
does from what the machine's load does to a live run: e.g. seed 1 with
`--set smooth_lagged_data=false` gives ATE 0.090 m as the messages arrived and 0.017 m in
stamp order (docs/ekf.md, "Lagged measurements").

Usage: replay_ekf_bag.py BAG [BAG ...] [--config YAML] [--set NAME=VALUE ...]
                         [--arrival bag|stamp]
"""
import argparse
import math
import os
import sys
import time

import numpy as np
import yaml

from my_summit_localization import ekf_config, ekf_runner, ekf_sensors
from my_summit_localization.odom_error import odom_error
from summit_nav_common.geometry import euler_from_matrix

HERE = os.path.dirname(os.path.abspath(__file__))
CONFIG = os.path.join(os.path.dirname(HERE), "config", "ekf.yaml")
TRUTH, RAW = "/base_pose_ground_truth", "/odom"


def _matrix(t):
    """4x4 of a geometry_msgs/Transform."""
    q, p = t.rotation, t.translation
    out = np.eye(4)
    out[:3, :3] = ekf_sensors.matrix_from_quaternion([q.x, q.y, q.z, q.w])
    out[:3, 3] = (p.x, p.y, p.z)
    return out


def static_mount(static, target, source):
    """4x4 target <- source through the static transforms {child: (parent, 4x4)}; None
    when source is target, ValueError when the chain does not reach target."""
    source = source.lstrip("/")
    if source == target:
        return None
    out, frame = np.eye(4), source
    while frame != target:
        if frame not in static:
            raise ValueError(f"no static transform {target} <- {source} in the bag")
        parent, m = static[frame]
        out, frame = m @ out, parent
    return out


def read_bag(path, topics):
    """(messages [(receive time [s], topic, msg)] of `topics`, static transforms,
    {topic: rows (t, x, y, yaw)} of the truth and the raw odometry)."""
    import rosbag
    msgs, static, tracks = [], {}, {TRUTH: [], RAW: []}
    with rosbag.Bag(path) as b:
        for topic, msg, t in b.read_messages():
            if topic == "/tf_static":
                for tr in msg.transforms:
                    static[tr.child_frame_id.lstrip("/")] = (tr.header.frame_id.lstrip("/"), _matrix(tr.transform))
                continue
            if topic in tracks:
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
                tracks[topic].append((msg.header.stamp.to_sec(), p.x, p.y, yaw))
            if topic in topics:
                msgs.append((t.to_sec(), topic, msg))
    return msgs, static, {k: np.array(v).reshape(-1, 4) for k, v in tracks.items()}


def measurements(config, sensor, msg, static):
    """The measurements ekf_localization_node makes of one message (odom or imu)."""
    s = sensor.state
    stamp = msg.header.stamp.to_sec()
    if sensor.kind == "odom":
        world = static_mount(static, config.world_frame, msg.header.frame_id) if s.uses_pose else None
        base = static_mount(static, config.base_link_frame, msg.child_frame_id) if s.uses_twist else None
        lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        r = ekf_sensors.matrix_from_quaternion([q.x, q.y, q.z, q.w])
        pose = np.array([p.x, p.y, p.z, *(euler_from_matrix(r) if r is not None else (math.nan,) * 3)])
        return ekf_sensors.odometry_measurements(
            s, stamp, pose, msg.pose.covariance, np.array([lin.x, lin.y, lin.z, ang.x, ang.y, ang.z]),
            msg.twist.covariance, world_from_frame=world, base_from_child=None if base is None else base[:3, :3])
    if sensor.kind == "imu":
        base = static_mount(static, config.base_link_frame, msg.header.frame_id)
        q, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
        return ekf_sensors.imu_measurements(
            s, stamp, [q.x, q.y, q.z, q.w], msg.orientation_covariance, [w.x, w.y, w.z],
            msg.angular_velocity_covariance, [a.x, a.y, a.z], msg.linear_acceleration_covariance,
            None if base is None else base[:3, :3])
    raise ValueError(f"{sensor.name}: only odom and imu sensors are replayed")


def replay(path, params, arrival="bag"):
    """Runs the cycle over the bag; returns (published rows (t, x, y, yaw), runner,
    truth rows, raw odometry rows, CPU seconds)."""
    config = ekf_config.read_config(params)
    sensors = {s.topic: s for s in config.sensors}
    msgs, static, tracks = read_bag(path, set(sensors))
    cpu0 = time.process_time()
    runner = ekf_runner.EkfRunner(config, list(sensors))
    if arrival == "stamp":
        events = sorted(((m.header.stamp.to_sec(), k, topic, m) for k, (_, topic, m) in enumerate(msgs)))
    else:
        events = sorted(((t, k, topic, m) for k, (t, topic, m) in enumerate(msgs)))
    period = 1.0 / config.frequency
    now, i, out, last = events[0][0], 0, [], None
    while i < len(events):
        while i < len(events) and events[i][0] <= now + 1e-9:
            _, _, topic, m = events[i]
            i += 1
            runner.add(topic, m.header.stamp.to_sec(), measurements(config, sensors[topic], m, static), now)
        runner.update(now)
        st = runner.state()
        if st is not None and (last is None or st[2] > last):
            last = st[2]
            out.append((st[2], st[0][0], st[0][1], st[0][5]))
        now += period
    runner.update(now)
    return np.array(out), runner, tracks[TRUTH], tracks[RAW], time.process_time() - cpu0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bags", nargs="+", help="tours recorded by bench_ekf.py (output/ekf_bags/seed<S>.bag)")
    ap.add_argument("--config", default=CONFIG, help="the EKF's YAML (robot_localization's format)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="override a parameter of the YAML (value read as YAML), e.g. smooth_lagged_data=false")
    ap.add_argument("--arrival", choices=("bag", "stamp"), default="bag",
                    help="messages reach the filter when recorded (bag) or in stamp order (stamp)")
    args = ap.parse_args()
    with open(args.config) as f:
        params = yaml.safe_load(f)
    for item in args.set:
        name, sep, value = item.partition("=")
        if not sep or not name:
            ap.error(f"--set {item}: expected NAME=VALUE")
        params[name] = yaml.safe_load(value)
    print(f"{'bag':<24} {'published':>9} {'heading':>8} {'ATE':>7} {'CPU/sim s':>9}  lagged")
    for path in args.bags:
        track, runner, truth, raw, cpu = replay(path, params, args.arrival)
        t_end = min(raw[-1, 0], track[-1, 0])
        e = odom_error(track, truth, t_end=t_end)
        print(f"{os.path.basename(path):<24} {len(track):9d} {math.degrees(e.final_heading):7.3f}d "
              f"{e.ate:6.4f}m {cpu / (truth[-1, 0] - truth[0, 0]):9.4f}  cycles gone back {runner.reverts}, "
              f"fused where the filter was {runner.lagged}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
