#!/usr/bin/python3
"""Benchmark the RBPF SLAM core offline on the CARMEN Intel and ACES logs.

For each log: read the FLASER scans and their corrected (reference) poses, make drifted
odometry from the reference increments (seeded), run RbpfSlam on every scan, and report
the ATE RMSE [m] of the SLAM trajectory (best particle's ancestry, at the processed
scans) and of the drifted odometry alone (same scans), CPU seconds (total and per
processed scan), peak RSS and map patch memory; writes a PNG of each map.

Parameters (BENCH_PARAMS below): gmapping's defaults except
  - particles 30 (the task's setting);
  - linearUpdate 0.2 m / angularUpdate 0.1 rad: the logs hold one scan every ~0.55 m /
    ~0.31 rad, so (nearly) every scan is used, as in the usual gmapping runs on these logs;
  - maxUrange 30 m (beyond that the 1-degree SICK beams are > 0.5 m apart); no-return
    readings (81.83 m in Intel) are beyond maxRange (80 m) and skipped, as gmapping does;
  - lskip 0 (only 180 beams, all are used).
Usage: bench_slam_carmen.py [--logs intel aces] [--particles 30] [--seed 0]
                            [--json PATH] [--out DIR] [--set name=value ...]
"""
import argparse
import json
import os
import resource
import sys
import time

import cv2
import numpy as np

from my_summit_mapping import carmen, metrics
from my_summit_mapping.rbpf import RbpfSlam
from my_summit_mapping.slam_config import SlamConfig

HERE = os.path.dirname(os.path.abspath(__file__))

DATA_DIR = os.path.join(HERE, "..", "..", "..", "data", "carmen")  # the workspace's data/
LOGS = {"intel": "intel-corrected.log.gz", "aces": "aces-corrected.log.gz"}
BENCH_PARAMS = dict(particles=30, linearUpdate=0.2, angularUpdate=0.1, maxUrange=30.0,
                    maxRange=80.0, xmin=-40.0, ymin=-40.0, xmax=40.0, ymax=40.0)
GMAPPING_PUBLISHED_ATE = {"intel": 0.070}  # gmapping's published Intel ATE [m], for reference
ODOM_SEED_OFFSET = 1000  # odometry noise and filter noise come from different streams


def run_log(name, path, params, seed, out_dir):
    log = carmen.read_carmen(path)
    odom = carmen.make_drifted_odometry(log.poses, np.random.default_rng(seed + ODOM_SEED_OFFSET))
    config = SlamConfig.from_dict(params)
    slam = RbpfSlam(config, np.random.default_rng(seed))
    used = []
    cpu0 = time.process_time()
    wall0 = time.time()
    for k in range(len(log.ranges)):
        if slam.process(odom[k], log.ranges[k], log.angles, (0.0, 0.0, 0.0), log.timestamps[k]):
            used.append(k)
    cpu = time.process_time() - cpu0
    wall = time.time() - wall0
    traj = slam.trajectory()
    used = np.array(used)
    result = dict(
        log=name, scans=len(log.ranges), processed_scans=len(used),
        ate_slam_m=metrics.ate_rmse(traj, log.poses[used]),
        ate_odom_m=metrics.ate_rmse(odom[used], log.poses[used]),
        cpu_s=cpu, wall_s=wall, cpu_ms_per_processed_scan=1000.0 * cpu / max(len(used), 1),
        resamples=slam.resample_count,
        map_patch_memory_mb=slam.map_memory_bytes() / 2 ** 20,
        peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        particles=config.particles)
    if name in GMAPPING_PUBLISHED_ATE:
        result["gmapping_published_ate_m"] = GMAPPING_PUBLISHED_ATE[name]
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
        png = os.path.join(out_dir, f"slam_{name}.png")
        write_png(slam.occupancy_grid(), traj, png)
        result["png"] = png
    return result


def write_png(grid, traj, path):
    """Map as map_saver colours (white free, black occupied, grey unknown), y up, path in red."""
    data, width, height, res, ox, oy = grid
    img = np.full((height, width), 205, np.uint8)
    d = data.reshape(height, width)
    img[d == 0] = 254
    img[d == 100] = 0
    # crop to the seen area
    seen = np.argwhere(d != -1)
    (r0, c0), (r1, c1) = seen.min(axis=0), seen.max(axis=0) + 1
    rgb = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    pts = np.round((traj[:, :2] - (ox, oy)) / res).astype(np.int32)
    cv2.polylines(rgb, [pts.reshape(-1, 1, 2)], False, (0, 0, 255), 1)
    cv2.imwrite(path, np.flipud(rgb[r0:r1, c0:c1]))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--logs", nargs="+", default=list(LOGS), choices=list(LOGS))
    parser.add_argument("--particles", type=int, default=BENCH_PARAMS["particles"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--data", default=DATA_DIR, help="directory of the CARMEN logs")
    parser.add_argument("--json", help="write the results as JSON to this path")
    parser.add_argument("--out", help="directory for the map PNGs")
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE",
                        help="override a gmapping parameter")
    args = parser.parse_args(argv)
    params = dict(BENCH_PARAMS, particles=args.particles)
    for item in args.set:
        key, value = item.split("=", 1)
        params[key] = float(value) if "." in value or "e" in value else int(value)
    results = []
    print(f"{'log':6} {'scans':>6} {'used':>5} {'ATE slam':>9} {'ATE odom':>9} {'CPU s':>7} "
          f"{'ms/scan':>8} {'RSS MB':>7} {'maps MB':>8}")
    for name in args.logs:
        res = run_log(name, os.path.join(args.data, LOGS[name]), params, args.seed, args.out)
        results.append(res)
        print(f"{name:6} {res['scans']:6d} {res['processed_scans']:5d} {res['ate_slam_m']:9.3f} "
              f"{res['ate_odom_m']:9.3f} {res['cpu_s']:7.1f} {res['cpu_ms_per_processed_scan']:8.1f} "
              f"{res['peak_rss_mb']:7.0f} {res['map_patch_memory_mb']:8.1f}", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(params=params, seed=args.seed, results=results), f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
