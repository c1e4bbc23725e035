#!/usr/bin/python3
"""Runs rostest files N times each, in a row, and prints the pass count of each.

    tools/repeat_tests.py -n 10 my_summit_localization/amcl_global.test tests/course_project.test
    tools/repeat_tests.py -n 10 --all          every rostest of the workspace
    tools/repeat_tests.py -n 4 -j 3 my_summit_path_planning/move_base_box.test
                                               4 rounds of 3 copies at once (make test's
                                               load: one pytest-xdist worker per CPU + 1)

A file is named as in `make test`'s case ids (package/file.test, or tests/file.test).
Each run is a separate rostest (own master, own ROS_HOME under output/repeat/<case>/run_K,
kept when the run failed). Exits non-zero when any run failed.
"""
import argparse
import concurrent.futures
import os
import shutil
import sys
import time

import rostest_files as rt  # the rostest files and how make test runs them (a sibling)
from summit_nav_common.testing.roslaunch_session import run_bounded

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", help="package/file.test as in make test's ids")
    ap.add_argument("-n", type=int, default=10, help="runs of each (default 10)")
    ap.add_argument("-j", type=int, default=1, help="copies of each run at once (default 1)")
    ap.add_argument("--all", action="store_true", help="every rostest of the workspace")
    args = ap.parse_args()
    by_id = {rt.case_id(p): p for p in rt.TEST_FILES}
    cases = sorted(by_id) if args.all else args.cases
    unknown = [c for c in cases if c not in by_id]
    if unknown or not cases or args.n < 1 or args.j < 1:
        ap.error(f"unknown case(s) {unknown}; known: {', '.join(sorted(by_id))}" if unknown
                 else "name at least one case (or --all), -n >= 1 and -j >= 1")
    failed_any = False
    for case in cases:
        passed, walls = 0, []
        for k in range(1, args.n + 1):
            runs = [f"run_{k}" if args.j == 1 else f"run_{k}_{c}" for c in range(1, args.j + 1)]
            with concurrent.futures.ThreadPoolExecutor(args.j) as pool:
                for name, (ok, wall) in zip(runs, pool.map(lambda r: run_once(by_id[case], case, r), runs)):
                    passed += ok
                    walls.append(wall)
                    if not ok:
                        print(f"  {case} {name}: FAILED (logs in output/repeat/{case.replace('/', '__')}/{name})",
                              flush=True)
        total = args.n * args.j
        failed_any |= passed < total
        print(f"{case}: {passed} of {total} passed, median {sorted(walls)[len(walls) // 2]:.0f} s wall",
              flush=True)
    return 1 if failed_any else 0


def run_once(test_file, case, run):
    """One rostest in its own ROS_HOME; (passed, wall seconds). The home is kept on failure."""
    home = os.path.join(WS, "output", "repeat", case.replace("/", "__"), run)
    shutil.rmtree(home, ignore_errors=True)
    os.makedirs(home)
    env = dict(os.environ, ROS_HOME=home, ROS_LOG_DIR=os.path.join(home, "log"))
    t0 = time.monotonic()
    rc, out = run_bounded(rt.rostest_command(test_file), env, rt.TIMEOUT)
    wall = time.monotonic() - t0
    ok = rc == 0 and "RESULT: SUCCESS" in out
    with open(os.path.join(home, "rostest.out"), "w") as f:
        f.write(out)
    if ok:
        shutil.rmtree(home, ignore_errors=True)
    return ok, wall


if __name__ == "__main__":
    sys.exit(main())
