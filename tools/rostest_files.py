"""The workspace's rostest files and how they are run, one rostest each (the integration
tier of `make test`: tests/test_rostest.py; and tools/repeat_tests.py).

rostest starts its own ROS master on a free port and stops everything it launched, also
on failure; the time-limit in each .test bounds its test node, and TIMEOUT bounds the
whole run (the process group is killed when it is exceeded).
"""
import glob
import os
import re

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TIMEOUT = 1500  # [s] wall time for one rostest run (each .test's time-limit bounds its test node)
# Each package's rostests, and the workspace's own end-to-end ones in tests/ (not a
# package: rostest is told the directory and a package name for its results).
TEST_FILES = sorted(glob.glob(os.path.join(WS, "src", "*", "test", "*.test"))) + \
    sorted(glob.glob(os.path.join(WS, "tests", "*.test")))
LONG_BELOW_SPEED = 2.0  # a .test whose simulator runs slower than this takes minutes


def package_of(path):
    if os.path.dirname(path) == os.path.join(WS, "tests"):
        return "tests"
    return os.path.basename(os.path.dirname(os.path.dirname(path)))


def rostest_command(path):
    if package_of(path) == "tests":
        name = os.path.splitext(os.path.basename(path))[0]
        return ["rostest", f"--pkgdir={os.path.dirname(path)}", f"--package={name}", path]
    return ["rostest", package_of(path), os.path.basename(path)]


def case_id(path):
    return f"{package_of(path)}/{os.path.basename(path)}"


def simulator_speed(path):
    """The simulator speed a .test sets (<arg name="speed" value|default="X"/>), or None."""
    with open(path) as f:
        m = re.search(r'<arg\s+name="speed"\s+(?:value|default)="([0-9.]+)"', f.read())
    return float(m.group(1)) if m else None


def is_long(path):
    """True for a .test of minutes (its simulator slower than LONG_BELOW_SPEED)."""
    speed = simulator_speed(path)
    return speed is not None and speed < LONG_BELOW_SPEED
