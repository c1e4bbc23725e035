#!/usr/bin/python3
"""Where the online error of a slam_bag run accrues, from its saved series (.npz).

bench_slam_bag.py saves per seed the scans' stamps, odometry and reference poses, the
online trajectory and every map -> odom broadcast. For each file this prints
  - the online ATE and the odometry's, and when map -> odom changed after each scan
    (online_eval.update_delays: a node lagging behind its updates shows here);
  - the error over time in BINS stretches of scans, after the one rigid alignment of the
    whole run (online_eval.error_series): RMS and largest position error [m], mean
    heading error [deg] (a part of the trajectory turned against the rest), and the
    summed along-track error of the steps [m] (online_eval.step_errors: a corridor
    stretched or shortened);
  - the largest single steps of the estimate against the reference's (a jump: the best
    particle changed, or a loop closed), with the odometry's step error for contrast.

Usage: slam_bag_errors.py NPZ [NPZ ...] [--bins 20] [--jumps 8]
  e.g. slam_bag_errors.py output/slam_bag_aces/slam_bag_seed*.npz
"""
import argparse
import sys

import numpy as np

from my_summit_mapping import metrics, online_eval


def report(path, bins, jumps):
    z = np.load(path)
    stamps, odom, ref, online, m2o = (z[k] for k in ("scan_stamps", "odometry", "reference", "online",
                                                     "map_to_odom"))
    delays, per_scan = online_eval.update_delays(stamps, m2o[:, 0], m2o[:, 1:])
    err, heading = online_eval.error_series(online, ref)
    dist = np.linalg.norm(err, axis=1)
    steps = online_eval.step_errors(online, ref)
    odom_steps = online_eval.step_errors(odom, ref)
    print(f"{path}: {len(stamps)} scans over {stamps[-1] - stamps[0]:.0f} s; online ATE "
          f"{metrics.ate_rmse(online, ref):.3f} m, odometry {metrics.ate_rmse(odom, ref):.3f} m")
    if len(delays):
        print(f"  map -> odom changed {len(delays)} times, {np.median(delays):.3f} s after its scan (median; "
              f"max {delays.max():.3f}); scans followed by none {int(np.sum(per_scan == 0))}, by more than one "
              f"{int(np.sum(per_scan > 1))}; median gap between scans {np.median(np.diff(stamps)):.3f} s")
    rms = lambda a: float(np.sqrt(np.mean(a ** 2)))  # noqa: E731
    print(f"  step error RMS along / across / heading: online {rms(steps[:, 0]):.3f} m / {rms(steps[:, 1]):.3f} m "
          f"/ {np.degrees(rms(steps[:, 2])):.2f} deg; odometry {rms(odom_steps[:, 0]):.3f} / "
          f"{rms(odom_steps[:, 1]):.3f} / {np.degrees(rms(odom_steps[:, 2])):.2f}")
    print(f"  {'scans':>9} {'t [s]':>6} {'RMS [m]':>8} {'max [m]':>8} {'heading [deg]':>13} {'along sum [m]':>13}")
    edges = np.linspace(0, len(stamps), bins + 1).astype(int)
    for a, b in zip(edges[:-1], edges[1:]):
        if b <= a:
            continue
        print(f"  {a:4d}-{b - 1:<4d} {stamps[a] - stamps[0]:6.0f} {rms(dist[a:b]):8.3f} {dist[a:b].max():8.3f} "
              f"{np.degrees(np.mean(heading[a:b])):+13.2f} {steps[a:min(b, len(steps)), 0].sum():+13.3f}")
    size = np.hypot(steps[:, 0], steps[:, 1])
    top = np.sort(np.argsort(-size)[:jumps])
    print("  largest steps (scan k -> k+1: position error [m], heading [deg]; odometry's):")
    for k in top:
        print(f"    {k:4d}: {size[k]:.2f} m {np.degrees(steps[k, 2]):+.2f} deg "
              f"(odometry {np.hypot(*odom_steps[k, :2]):.2f} m {np.degrees(odom_steps[k, 2]):+.2f} deg)")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("npz", nargs="+", help="slam_bag_seed<N>.npz from bench_slam_bag.py")
    parser.add_argument("--bins", type=int, default=20, help="stretches of scans for the error over time")
    parser.add_argument("--jumps", type=int, default=8, help="how many of the largest steps to list")
    args = parser.parse_args(argv)
    if args.bins < 1 or args.jumps < 0:
        print("slam_bag_errors: error: --bins must be >= 1 and --jumps >= 0", file=sys.stderr)
        return 2
    for path in args.npz:
        try:
            report(path, args.bins, args.jumps)
        except (OSError, KeyError, ValueError) as e:
            print(f"slam_bag_errors: error: {path}: {e}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
