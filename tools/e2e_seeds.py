#!/usr/bin/python3
"""Runs the end-to-end rostest (tests/course_project.test) for several simulator seeds
and prints one line per run and the pass count (issue 6's figure: 10 of 10).

    make e2e-seeds                 seeds 1..10
    make e2e-seeds SEEDS="3 7"     these seeds
    tools/e2e_seeds.py --speed 4   at 4x real time

Each line also names the scans amcl, slam_gmapping and move_base had to skip because they
fell behind (their ~scans_skipped).

Each run is a separate rostest (own master, own ROS_HOME under output/e2e_seeds/seed_N,
where its logs, saved map and spots.txt stay for inspection).
"""
import argparse
import os
import re
import sys
import time

from summit_nav_common.testing.roslaunch_session import run_bounded

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TEST = os.path.join(WS, "tests", "course_project.test")
TIMEOUT = 1500.0  # [s] wall, one run


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seeds", nargs="*", type=int, default=list(range(1, 11)))
    ap.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall second")
    ap.add_argument("--load", choices=("none", "one_core", "cpu_hog"), default="none",
                    help="one_core: the run confined to one CPU (the rostest's default); cpu_hog: a "
                         "process spinning beside it; none: neither")
    args = ap.parse_args()
    out_dir = os.path.join(WS, "output", ("e2e_seeds" if args.speed == 1.0 else f"e2e_seeds_{args.speed:g}x")
                           + ("" if args.load == "none" else "_" + args.load))
    passed = 0
    for seed in args.seeds:
        home = os.path.join(out_dir, f"seed_{seed}")
        os.makedirs(home, exist_ok=True)
        env = dict(os.environ, ROS_HOME=home, ROS_LOG_DIR=os.path.join(home, "log"))
        t0 = time.monotonic()
        rc, out = run_bounded(["rostest", f"--pkgdir={os.path.dirname(TEST)}", "--package=course_project", TEST,
                               f"seed:={seed}", f"speed:={args.speed}",
                               f"one_core:={str(args.load == 'one_core').lower()}",
                               f"cpu_hog:={str(args.load == 'cpu_hog').lower()}"], env, TIMEOUT)
        with open(os.path.join(home, "rostest.out"), "w") as f:
            f.write(out)
        ok = rc == 0 and "RESULT: SUCCESS" in out
        passed += ok
        results = _results(home)
        failure = re.search(r"<failure[^>]*>([^\n]*)", results)
        skipped = re.search(r"SCANS_SKIPPED ([^\n<]*)", out + results)
        print(f"seed {seed}: {'PASS' if ok else 'FAIL'} in {time.monotonic() - t0:.0f} s wall; scans skipped: "
              + (skipped.group(1).strip() if skipped else "not reported")
              + ("" if ok else f": {failure.group(1)[:300] if failure else 'rc ' + str(rc)}"), flush=True)
    print(f"{passed} passed, {len(args.seeds) - passed} failed")
    return 0 if passed == len(args.seeds) else 1


def _results(home):
    """The rostest's JUnit XML text (empty when there is none)."""
    for root, _, files in os.walk(os.path.join(home, "test_results")):
        for name in files:
            if name.startswith("rosunit-") and name.endswith(".xml"):
                with open(os.path.join(root, name)) as f:
                    return f.read()
    return ""


if __name__ == "__main__":
    sys.exit(main())
