#!/usr/bin/python3
"""Benchmark of frontier exploration (explore.launch) from seeded start poses.

For each run: the simulator on the world with the robot at a seeded random free pose
(at least CLEARANCE m from any obstacle), slam_gmapping (or slam_karto, --slam karto) +
move_base on the live map + explore, until explore says it is over (or the wall-time limit). Reported per run:
explored share of the reachable free area (my_summit_navigation.frontiers.
exploration_coverage), simulated and wall time, collisions, why it ended, and the map's
precision / recall against the true walls with the SLAM trajectory's ATE (the mapping
benchmark's evaluation), and the SLAM node's peak resident memory (VmHWM) at the end.

    bench_explore.py [--world builtin|willow] [--runs 5] [--seed 0] [--speed 3]
                     [--slam gmapping|karto] [--json PATH]
                     [--node EXECUTABLE [--node-setup SETUP_BASH]]

--node runs another executable with the SLAM node's interface in ours' place (e.g. the
real slam_karto, with the same YAML), through explore.launch's slam_launch_prefix: a
script that drops our node's path from the command and runs EXECUTABLE with the rest (the
name, the remappings), in the environment --node-setup adds (sourced --extend).

Each run is a child process (rospy binds one process to one ROS master).
"""
import argparse
import json
import math
import os
import shlex
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
WORLDS = {
    "builtin": os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml"),
    # willow-full with its unknown cells solid: through the gaps of its dashed walls the
    # building leaks into the open unknown space around it, and the robot explored that,
    # on to the map's edge (see summit_xl_sim.world).
    "willow": os.path.join(WS, "src", "my_summit_navigation", "maps", "willow-full-closed.yaml"),
    "two_rooms": os.path.join(WS, "src", "summit_xl_sim", "worlds", "two_rooms.yaml"),
}
CLEARANCE = 0.8          # [m] start poses at least this far from obstacles
# [s] per run; willow's leaves room for explore's second-chance round at the end
WALL_LIMIT = {"builtin": 900.0, "willow": 3600.0, "two_rooms": 400.0}
SLAM_NODE = {"gmapping": "slam_gmapping", "karto": "slam_karto"}   # explore.launch's node names
FINAL_MAP_WAIT = 60.0    # [s wall] after the end for a map stamped at it (maps come every 5 s)


def start_poses(world_yaml, n, seed):
    """n seeded (x, y, yaw) in the world's main free component, CLEARANCE from obstacles."""
    import cv2
    from scipy import ndimage
    from summit_nav_common.map_io import load_map
    m = load_map(world_yaml)
    free = m.data == 0
    labels, k = ndimage.label(free)
    main = labels == (np.argmax(np.bincount(labels.ravel())[1:]) + 1)
    dist = cv2.distanceTransform(main.astype(np.uint8), cv2.DIST_L2, 5) * m.resolution
    rr, cc = np.nonzero(dist >= CLEARANCE)
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(rr), size=n, replace=False)
    return [(float(m.origin[0] + (cc[i] + 0.5) * m.resolution), float(m.origin[1] + (rr[i] + 0.5) * m.resolution),
             float(rng.uniform(-math.pi, math.pi))) for i in pick]


def judged_range(slam):
    """[m] how far the SLAM node maps, so the walls recall is judged on: gmapping's
    maxUrange from the project's gmapping_params.yaml, karto's range_threshold."""
    if slam == "karto":
        from my_summit_mapping.karto.mapper import KartoParams
        return KartoParams().range_threshold
    import yaml
    from my_summit_mapping.slam_config import SlamConfig
    with open(os.path.join(WS, "src", "my_summit_mapping", "config", "gmapping_params.yaml")) as f:
        return SlamConfig.from_dict(yaml.safe_load(f)).maxUrange


def node_prefix(path, node, setup=None):
    """Write to `path` the launch prefix that runs `node` instead of the launched SLAM
    node: roslaunch calls it as PREFIX OUR_NODE ARGS..., it runs NODE ARGS... after
    sourcing `setup` (--extend). Returns path."""
    lines = ["#!/bin/bash", "# written by bench_explore.py: run another SLAM node in ours' place", "shift"]
    if setup:
        lines.append(f"source {shlex.quote(setup)} --extend")
    lines.append(f'exec {shlex.quote(node)} "$@"')
    with open(path + ".part", "w") as f:
        f.write("\n".join(lines) + "\n")
    os.chmod(path + ".part", 0o755)
    os.replace(path + ".part", path)
    return path


def one_run(world_name, pose, speed, out_dir, slam="gmapping", node=None, node_setup=None):
    """One exploration in this process (with `node` in place of our SLAM node when
    given); returns the result dict."""
    from summit_nav_common.testing.roslaunch_session import (RoslaunchSession, find_node_pid, peak_rss_mb,
                                                             wait_for_sim_time_param)
    world_yaml = WORLDS[world_name]
    x, y, yaw = pose
    tag = slam + ("_peer" if node else "")
    log = os.path.join(out_dir, f"explore_{world_name}_{tag}_{x:.1f}_{y:.1f}.log")
    args = ["my_summit_navigation", "explore.launch", "sim:=true", f"world:={world_yaml}", f"x:={x}", f"y:={y}",
            f"yaw:={yaw}", f"speed:={speed}", f"save_map:={os.path.splitext(log)[0]}_map",
            f"debug_dump:={os.path.splitext(log)[0]}_dwa", f"slam:={slam}"]
    if node:
        args.append("slam_launch_prefix:=" + node_prefix(os.path.splitext(log)[0] + "_node.sh", node, node_setup))
    with RoslaunchSession(args, log=log) as session:
        wait_for_sim_time_param(session)
        import rospy
        from std_msgs.msg import Bool, String, UInt32
        from my_summit_mapping.tour_recorder import TourRecorder, write_png
        from my_summit_navigation.frontiers import exploration_coverage
        from summit_nav_common.map_io import load_map
        from summit_xl_sim.sim import LaserParams
        from summit_xl_sim.world import World
        rospy.init_node("bench_explore", anonymous=True, disable_signals=True)
        # another node (the real slam_karto) has no ~trajectory: its online pose from tf
        rec = TourRecorder(f"slam_{slam}", trajectory_from_tf=bool(node))
        st = {"done": False, "summary": None, "coll": 0}
        rospy.Subscriber("/explore/done", Bool, lambda m: st.update(done=m.data), queue_size=1)
        rospy.Subscriber("/explore/summary", String, lambda m: st.update(summary=m.data), queue_size=1)
        rospy.Subscriber("/collisions", UInt32, lambda m: st.update(coll=max(st["coll"], m.data)), queue_size=5)
        w0 = time.monotonic()
        while not rospy.is_shutdown() and not (st["done"] and st["summary"]):
            if not session.alive() or time.monotonic() - w0 > WALL_LIMIT[world_name]:
                break
            time.sleep(0.5)
        sim_t = rospy.Time.now().to_sec()
        wall_t = time.monotonic() - w0
        slam_pid = find_node_pid(session.proc.pid, SLAM_NODE[slam])
        slam_rss = peak_rss_mb(slam_pid) if slam_pid else float("nan")
        # a map stamped after the end, for the evaluation; a node that has stopped
        # publishing (the real slam_karto, once the robot stands still) is judged on its
        # last map, whose stamp the result records
        t_end = sim_t
        w_end = time.monotonic()
        while time.monotonic() - w_end < FINAL_MAP_WAIT and session.alive():
            with rec.lock:
                m, p = rec.map_msg, rec.path_msg
            if m is not None and p is not None and m.header.stamp.to_sec() >= t_end - 5.0:
                break
            time.sleep(0.5)
        with rec.lock:
            m = rec.map_msg
        map_stamp = m.header.stamp.to_sec()
        world_map = load_map(world_yaml)
        grid = np.asarray(m.data, np.int8).reshape(m.info.height, m.info.width)
        cov = exploration_coverage(world_map.data, world_map.resolution, world_map.origin[:2], pose, grid,
                                   m.info.resolution, (m.info.origin.position.x, m.info.origin.position.y))
        world = World.from_yaml(world_yaml)
        quality = rec.evaluate(world, judged_range(slam), LaserParams())
        # the map judged against the true walls, with the true and SLAM trajectories
        write_png(quality, os.path.splitext(log)[0] + "_judged.png", world)
    return {"world": world_name, "slam": slam, "node": node, "start": [round(v, 3) for v in pose], "coverage": round(cov, 4),
            "finished": bool(st["done"]), "summary": st["summary"], "sim_s": round(sim_t, 1),
            "map_stamp_s": round(map_stamp, 1),
            "wall_s": round(wall_t, 1), "collisions": int(st["coll"]), "ate_m": round(quality["ate_m"], 4),
            "ate_of": "online (tf map -> base_footprint)" if node else "the node's ~trajectory",
            "precision": round(quality["precision"], 4), "recall": round(quality["recall"], 4),
            "slam_peak_rss_mb": round(slam_rss, 1)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", choices=sorted(WORLDS), default="builtin")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--speed", type=float, default=3.0)
    ap.add_argument("--slam", choices=("gmapping", "karto"), default="gmapping", help="the SLAM node explore.launch runs")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--node", metavar="EXECUTABLE", help="run this SLAM node (e.g. the real slam_karto) in ours' place")
    ap.add_argument("--node-setup", metavar="SETUP_BASH", help="source this file (--extend) for --node's environment")
    ap.add_argument("--child", nargs=3, type=float, help=argparse.SUPPRESS)
    ap.add_argument("--child-out", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    from summit_nav_common.testing.roslaunch_session import check_node_args
    try:
        check_node_args(args.node, args.node_setup)
    except ValueError as e:
        ap.error(str(e))
    node = args.node and os.path.abspath(args.node)
    node_setup = args.node_setup and os.path.abspath(args.node_setup)
    out_dir = os.path.join(WS, "output", "bench_explore")
    os.makedirs(out_dir, exist_ok=True)
    if args.child:
        res = one_run(args.world, tuple(args.child), args.speed, out_dir, args.slam, node, node_setup)
        text = json.dumps(res)   # all of it or nothing: the parent reads what is there
        with open(args.child_out + ".part", "w") as f:
            f.write(text)
        os.replace(args.child_out + ".part", args.child_out)
        return 0
    runs = []
    for i, pose in enumerate(start_poses(WORLDS[args.world], args.runs, args.seed)):
        tmp = os.path.join(out_dir, f".run_{args.world}_{i}.json")
        if os.path.exists(tmp):
            os.remove(tmp)
        subprocess.run([sys.executable, os.path.abspath(__file__), "--world", args.world, "--speed", str(args.speed),
                        "--slam", args.slam, "--child", *map(str, pose), "--child-out", tmp]
                       + (["--node", node] if node else []) + (["--node-setup", node_setup] if node_setup else []))
        if os.path.exists(tmp):
            with open(tmp) as f:
                r = json.load(f)
            os.remove(tmp)
        else:
            r = {"world": args.world, "start": list(pose), "coverage": 0.0, "finished": False,
                 "summary": "the run crashed (see output/bench_explore/*.log)"}
        runs.append(r)
        print(json.dumps(r), flush=True)
    covs = [r["coverage"] for r in runs]
    summary = {"world": args.world, "slam": args.slam, "node": node, "runs": runs, "coverage_min": min(covs), "coverage_median": float(np.median(covs)),
               "all_finished": all(r["finished"] for r in runs),
               "collisions": sum(r.get("collisions", 0) for r in runs),
               "sim_s_median": float(np.median([r.get("sim_s", 0.0) for r in runs]))}
    print(json.dumps({k: v for k, v in summary.items() if k != "runs"}))
    if args.json:
        with open(args.json + ".part", "w") as f:
            json.dump(summary, f, indent=1)
        os.replace(args.json + ".part", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
