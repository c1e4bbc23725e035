#!/usr/bin/python3
"""Run the karto graph SLAM core on a CARMEN log (or a carmen_to_bag bag) without ROS.

The scans are what the live benchmark's bag gives a node for a seed (slam_bag_offline's
load_scans: the corrected log's scans, the odometry drifted with the seed as
carmen_bag.bag_scans draws it, rounded as the bag's messages round them). Every scan goes
to KartoMapper.add_scan in order with its odometry pose, as the node would hand them on.
Scored as the live runs are (online_eval): the online estimate of scan k is map -> odom
after scan k times its odometry, aligned to the corrected poses (ATE RMSE after the best
rigid 2D alignment); the final ATE takes the node poses after the last optimization
against the corrected poses of their scans. CPU is process time over the add_scan calls;
per node ("per processed scan").

Usage: karto_offline.py LOG [--seeds 1 2 3 4 5] [--set name=value ...] [--json PATH]
                            [--map PNG] [--save PATH]
"""
import argparse
import json
import os
import resource
import statistics
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")   # as nodes/slam_karto: its CPU, not a spinning thread's

import numpy as np  # noqa: E402

from my_summit_mapping import carmen, carmen_bag, metrics, online_eval
from my_summit_mapping.karto.mapper import KartoMapper, KartoParams, LaserGeometry


def load_scans(log, seed, carmen_log=None):
    """The scans a node gets for `seed` from LOG (as slam_bag_offline.load_scans)."""
    if log.endswith(".bag"):
        return carmen_bag.read_bag(log)
    return carmen_bag.as_received(carmen_bag.bag_scans(carmen_log or carmen.read_carmen(log), seed))


def parse_set(items):
    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"--set expects name=value, got {item!r}")
        key, value = item.split("=", 1)
        if value.lower() in ("true", "false"):
            out[key] = value.lower() == "true"
            continue
        try:
            out[key] = int(value)
        except ValueError:
            out[key] = float(value)
    return out


def laser_of(scans):
    return LaserGeometry(angle_min=float(scans.angle_min), angle_increment=float(scans.angle_increment),
                         n_beams=int(scans.ranges.shape[1]), range_min=0.0, range_max=float(scans.range_max),
                         mount=(float(scans.laser_offset), 0.0, 0.0))


def run(scans, overrides=None):
    """Feed scans (carmen_bag.BagScans) to a KartoMapper; (result dict, mapper)."""
    params, notes = KartoParams.from_params(overrides or {})
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    mapper = KartoMapper(params, laser_of(scans))
    m2o = np.zeros((len(scans.stamps), 3))
    node_scan = []
    cpu0 = time.process_time()
    for k in range(len(scans.stamps)):
        res = mapper.add_scan(scans.ranges[k], scans.odometry[k], float(scans.stamps[k]))
        if res is not None:
            node_scan.append(k)
        m2o[k] = mapper.map_to_odom()
    cpu = time.process_time() - cpu0
    online = online_eval.compose(m2o, scans.odometry)
    nodes = len(node_scan)
    return dict(seed=int(scans.seed), scans=len(scans.stamps), nodes=nodes,
                ate_online_m=metrics.ate_rmse(online, scans.reference),
                ate_final_m=metrics.ate_rmse(mapper.node_poses(), scans.reference[node_scan]),
                ate_odom_m=metrics.ate_rmse(scans.odometry, scans.reference),
                cpu_s=cpu, cpu_ms_per_scan=1000.0 * cpu / max(nodes, 1),
                loop_closures=mapper.stats["loop_closures"],
                rejected_loop_closures=mapper.stats["rejected_loop_closures"],
                edges=len(mapper.edges()),
                peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0), mapper


def save_png(mapper, path):
    import cv2
    grid, _ = mapper.occupancy_grid()
    img = np.full(grid.shape, 128, np.uint8)
    img[grid == 0] = 255
    img[grid == 100] = 0
    cv2.imwrite(path, img[::-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", help="CARMEN log (.log/.log.gz) or a bag from carmen_to_bag.py")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE", help="KartoParams overrides")
    parser.add_argument("--json", help="write the results as JSON to this path")
    parser.add_argument("--map", help="write the (first seed's) final map as a PNG here")
    parser.add_argument("--save", help="serialize the (first seed's) pose graph here")
    args = parser.parse_args(argv)
    overrides = parse_set(args.set)
    log = None if args.log.endswith(".bag") else carmen.read_carmen(args.log)
    results = []
    print(f"{'seed':>4} {'scans':>6} {'nodes':>6} {'ATE online':>10} {'ATE final':>9} {'ATE odom':>9} "
          f"{'CPU s':>7} {'ms/scan':>8} {'loops':>6} {'rejected':>8} {'RSS MB':>7}")
    for seed in args.seeds:
        r, mapper = run(load_scans(args.log, seed, log), overrides)
        if not results:
            if args.map:
                save_png(mapper, args.map)
            if args.save:
                mapper.save(args.save)
        results.append(r)
        print(f"{seed:4d} {r['scans']:6d} {r['nodes']:6d} {r['ate_online_m']:10.3f} {r['ate_final_m']:9.3f} "
              f"{r['ate_odom_m']:9.3f} {r['cpu_s']:7.1f} {r['cpu_ms_per_scan']:8.1f} {r['loop_closures']:6d} "
              f"{r['rejected_loop_closures']:8d} {r['peak_rss_mb']:7.0f}", flush=True)
        for line in mapper.log:
            print(f"  {line}")
    if len(results) > 1:
        on = [r["ate_online_m"] for r in results]
        fin = [r["ate_final_m"] for r in results]
        cpu = [r["cpu_ms_per_scan"] for r in results]
        print(f"median: online ATE {statistics.median(on):.3f} m (worst {max(on):.3f}), final ATE "
              f"{statistics.median(fin):.3f} m, CPU {statistics.median(cpu):.1f} ms per scan")
    if args.json:
        tmp = args.json + ".tmp"
        with open(tmp, "w") as f:
            json.dump(dict(log=os.path.abspath(args.log), overrides=overrides, runs=results), f, indent=2)
        os.replace(tmp, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
