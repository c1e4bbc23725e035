#!/usr/bin/python3
"""Convert a CARMEN corrected log to a rosbag for the live slam_gmapping node.

The bag (my_summit_mapping.carmen_bag): /scan (sensor_msgs/LaserScan, frame base_laser,
no return = +inf), /tf odom -> base_link (the corrected poses with seeded drift,
Probabilistic Robotics' odometry model), /tf_static base_link -> base_laser, and the
corrected poses on /reference_pose, at the log's timestamps. Same log and seed, same bag.

Usage: carmen_to_bag.py LOG OUT.bag [--seed 0]
  e.g. carmen_to_bag.py data/carmen/intel-corrected.log.gz /tmp/intel.bag --seed 1
Exit status 2 with a message naming the file when LOG is missing or not a CARMEN log.
"""
import argparse
import sys

from my_summit_mapping import carmen, carmen_bag


def convert(log_path, bag_path, seed):
    """Convert; returns the BagScans written. Raises OSError / ValueError on bad input."""
    log = carmen.read_carmen(log_path)
    scans = carmen_bag.bag_scans(log, seed)
    carmen_bag.write_bag(scans, bag_path)
    return scans


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", help="CARMEN log (.log or .log.gz) with FLASER lines")
    parser.add_argument("bag", help="the rosbag to write")
    parser.add_argument("--seed", type=int, default=0, help="seed of the odometry drift")
    args = parser.parse_args(argv)
    try:
        scans = convert(args.log, args.bag, args.seed)
    except (OSError, ValueError) as e:
        print(f"carmen_to_bag: error: {e}", file=sys.stderr)
        return 2
    m, n = scans.ranges.shape
    print(f"{args.bag}: {m} scans x {n} beams over {scans.stamps[-1] - scans.stamps[0]:.0f} s, no return "
          f"{scans.range_max:g} m -> inf ({int((scans.ranges == float('inf')).sum())} readings), "
          f"{scans.stamps_moved} stamps moved forward, drift seed {scans.seed}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
