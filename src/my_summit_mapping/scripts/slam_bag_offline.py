#!/usr/bin/python3
"""Replay a CARMEN log's bag content through the RBPF core as the live node would, without ROS.

The live benchmark (bench_slam_bag.py) plays a bag into nodes/slam_gmapping; when the node
keeps up it processes every scan in order with the same parameters (bench_slam_bag's
node_params), the same laser mount and the filter's rng seeded with the run's seed, so
this replay makes the same filter updates and scores the same online estimate (the
map -> odom after the latest update at or before each scan, composed with the odometry;
online_eval). The scans are what the node receives: a bag's as read back, a CARMEN log's
rounded as the bag's messages round them (carmen_bag.as_received), the beam angles as
the node turns them into the base frame; the filter is chaotic, and anything less gives
another run. (Runs are not bit-reproducible even so: two processes can differ by 1e-15 m
after some tens of updates, which the filter may amplify; the live ACES seeds 1-3 at rate
4 came out of one replay of the log to the millimetre.) It is cheap enough to search for
a seed's divergence (--updates N stops after N filter updates) or to see a figure's
spread over many seeds.

--as-gmapping replays with two conventions of the real slam_gmapping that move its result
but not its quality (as_gmapping): its beams sit half an angle increment before the scan's
own angles (GMapping::RangeSensor starts at -n/2 increments from the scan's centre), and its
cell borders lie half a cell off multiples of delta from its map's centre. With one particle
and no motion noise (--set particles=1 srr=0 srt=0 str=0 stt=0) the filter is deterministic,
and this replay then follows the real node's live run (bench_slam_bag.py --node ... with the
same --set) update for update: the oracle that the scan matcher and maps are gmapping's
(all 440 updates of ACES; on Intel they part after 374 updates at a near-tie that the
maps' rounding decides, and the map bounds must be +-100 m for gmapping's free-cell
check to stay off its map: docs/slam.md).

Usage: slam_bag_offline.py LOG [--seeds 1 2] [--updates N] [--set name=value ...]
                               [--json PATH] [--profile PATH] [--as-gmapping]
"""
import argparse
import cProfile
import json
import os
import resource
import statistics
import sys
import time
from dataclasses import replace

import numpy as np

from bench_slam_bag import node_params, parse_set
from my_summit_mapping import carmen, carmen_bag, laser_mount, metrics, online_eval
from my_summit_mapping.rbpf import RbpfSlam
from my_summit_mapping.slam_config import SlamConfig

HERE = os.path.dirname(os.path.abspath(__file__))


def as_gmapping(scans, params):
    """(scans, beam angles) with the real slam_gmapping's conventions (module docstring):
    the odometry moved so that our cell borders (multiples of delta) fall where its do
    (its map centre + half a cell, modulo delta; the online ATE does not see a shift of the
    whole run), the beams turned back by half an increment."""
    delta = params["delta"]
    centre = np.array([(params["xmin"] + params["xmax"]) / 2.0, (params["ymin"] + params["ymax"]) / 2.0])
    shift = -np.mod(centre + 0.5 * delta, delta)
    odometry = scans.odometry.copy()
    odometry[:, :2] += shift
    return replace(scans, odometry=odometry), beam_angles(scans) - 0.5 * scans.angle_increment


def replay(scans, seed, overrides=None, max_updates=None, gmapping_conventions=False):
    """Feed scans (carmen_bag.BagScans) to RbpfSlam as the node does; a result dict.
    gmapping_conventions: as the real node would (as_gmapping)."""
    params = node_params(scans, overrides)
    slam = RbpfSlam(SlamConfig.from_dict(params), np.random.default_rng(seed))
    scans, angles = as_gmapping(scans, params) if gmapping_conventions else (scans, beam_angles(scans))
    laser = (float(scans.laser_offset), 0.0, 0.0)
    m2o = np.zeros((len(scans.stamps), 3))
    current = np.zeros(3)
    cpu0 = time.process_time()
    k_end = len(scans.stamps)
    for k in range(len(scans.stamps)):
        ranges = scans.ranges[k].copy()
        if slam.process(scans.odometry[k], ranges, angles, laser, timestamp=float(scans.stamps[k]),
                        range_max=float(scans.range_max)):
            current = slam.map_to_odom()
        m2o[k] = current
        if max_updates is not None and slam.update_count >= max_updates:
            k_end = k + 1
            break
    cpu = time.process_time() - cpu0
    online = online_eval.compose(m2o[:k_end], scans.odometry[:k_end])
    ref = scans.reference[:k_end]
    return dict(seed=seed, scans=k_end, updates=slam.update_count,
                ate_online_m=metrics.ate_rmse(online, ref),
                ate_odom_m=metrics.ate_rmse(scans.odometry[:k_end], ref),
                ate_best_path_m=metrics.ate_rmse(slam.trajectory(), ref[_update_scans(slam, scans, k_end)]),
                cpu_s=cpu, cpu_ms_per_update=1000.0 * cpu / max(slam.update_count, 1),
                resamples=slam.resample_count,
                peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0), slam


def beam_angles(scans):
    """Beam directions (n,) [rad] in the base frame, as the node computes them for the
    bag's level, unrotated laser mount."""
    return laser_mount.beam_angles_in_base(np.eye(3), scans.angle_min, scans.angle_increment,
                                           scans.ranges.shape[1])


def load_scans(log, seed, carmen_log=None):
    """The scans the node gets for `seed` from LOG: a bag's as stored, a CARMEN log's (or
    the already read carmen_log's) drifted with the seed and rounded as in its bag."""
    if log.endswith(".bag"):
        return carmen_bag.read_bag(log)
    return carmen_bag.as_received(carmen_bag.bag_scans(carmen_log or carmen.read_carmen(log), seed))


def _update_scans(slam, scans, k_end):
    """Indices of the scans the filter updated on (matched by timestamp)."""
    return np.searchsorted(scans.stamps[:k_end], slam.trajectory_times())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", help="CARMEN log (.log/.log.gz) or a bag from carmen_to_bag.py")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--updates", type=int, help="stop after this many filter updates")
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--json", help="write the results as JSON to this path")
    parser.add_argument("--profile", help="cProfile the (first seed's) run into this .pstats path")
    parser.add_argument("--as-gmapping", action="store_true",
                        help="the real node's beam angles and cell borders (see the module docstring)")
    args = parser.parse_args(argv)
    overrides = parse_set(args.set)
    log = None if args.log.endswith(".bag") else carmen.read_carmen(args.log)
    results = []
    print(f"{'seed':>4} {'scans':>6} {'updates':>7} {'ATE online':>10} {'ATE path':>9} {'ATE odom':>9} "
          f"{'CPU s':>7} {'ms/update':>9} {'resamples':>9} {'RSS MB':>7}")
    for seed in args.seeds:
        scans = load_scans(args.log, seed, log)
        prof = cProfile.Profile() if args.profile and not results else None
        if prof:
            prof.enable()
        r, _ = replay(scans, seed, overrides, args.updates, args.as_gmapping)
        if prof:
            prof.disable()
            prof.dump_stats(args.profile)
        results.append(r)
        print(f"{seed:4d} {r['scans']:6d} {r['updates']:7d} {r['ate_online_m']:10.3f} {r['ate_best_path_m']:9.3f} "
              f"{r['ate_odom_m']:9.3f} {r['cpu_s']:7.1f} {r['cpu_ms_per_update']:9.1f} {r['resamples']:9d} "
              f"{r['peak_rss_mb']:7.0f}", flush=True)
    if len(results) > 1:
        ates = [r["ate_online_m"] for r in results]
        print(f"online ATE median {statistics.median(ates):.3f} m, worst {max(ates):.3f} m")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(log=os.path.abspath(args.log), overrides=overrides, runs=results), f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
