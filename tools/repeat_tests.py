#!/usr/bin/python3
"""Runs rostest files N times each, in a row, and prints the pass count of each.

    tools/repeat_tests.py -n 10 my_summit_localization/amcl_global.test tests/course_project.test
    tools/repeat_tests.py -n 10 --all          every rostest of the workspace

A file is named as in `make test`'s case ids (package/file.test, or tests/file.test).
Each run is a separate rostest (own master, own ROS_HOME under output/repeat/<case>/run_K,
kept when the run failed). Exits non-zero when any run failed.
"""
import argparse
import os
import shutil
import sys
import time

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(WS, "tests"))
sys.path.insert(0, os.path.join(WS, "tools"))
import test_rostest as rt  # noqa: E402  (the rostest files and how make test runs them)
from roslaunch_session import run_bounded  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", help="package/file.test as in make test's ids")
    ap.add_argument("-n", type=int, default=10, help="runs of each (default 10)")
    ap.add_argument("--all", action="store_true", help="every rostest of the workspace")
    args = ap.parse_args()
    by_id = {rt.case_id(p): p for p in rt.TEST_FILES}
    cases = sorted(by_id) if args.all else args.cases
    unknown = [c for c in cases if c not in by_id]
    if unknown or not cases or args.n < 1:
        ap.error(f"unknown case(s) {unknown}; known: {', '.join(sorted(by_id))}" if unknown
                 else "name at least one case (or --all) and -n >= 1")
    failed_any = False
    for case in cases:
        passed, walls = 0, []
        for k in range(1, args.n + 1):
            home = os.path.join(WS, "output", "repeat", case.replace("/", "__"), f"run_{k}")
            shutil.rmtree(home, ignore_errors=True)
            os.makedirs(home)
            env = dict(os.environ, ROS_HOME=home, ROS_LOG_DIR=os.path.join(home, "log"))
            t0 = time.monotonic()
            rc, out = run_bounded(rt.rostest_command(by_id[case]), env, rt.TIMEOUT)
            walls.append(time.monotonic() - t0)
            ok = rc == 0 and "RESULT: SUCCESS" in out
            passed += ok
            with open(os.path.join(home, "rostest.out"), "w") as f:
                f.write(out)
            if ok:
                shutil.rmtree(home, ignore_errors=True)
            else:
                print(f"  {case} run {k}: FAILED (logs in {os.path.relpath(home, WS)})", flush=True)
        failed_any |= passed < args.n
        print(f"{case}: {passed} of {args.n} passed, median {sorted(walls)[len(walls) // 2]:.0f} s wall",
              flush=True)
    return 1 if failed_any else 0


if __name__ == "__main__":
    sys.exit(main())
