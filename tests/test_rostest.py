"""Runs every rostest .test file of the workspace, one pytest case each.

rostest starts its own ROS master on a free port and stops everything it launched, also
on failure; the time-limit in each .test bounds its test node, and TIMEOUT bounds the
whole run here (the process group is killed when it is exceeded).
"""
import glob
import os
import re
import sys

import pytest

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(WS, "tools"))
from roslaunch_session import run_bounded  # noqa: E402
TIMEOUT = 1500  # [s] wall time for one rostest run (each .test's time-limit bounds its test node)
# Each package's rostests, and the workspace's own end-to-end ones in tests/ (not a
# package: rostest is told the directory and a package name for its results).
TEST_FILES = sorted(glob.glob(os.path.join(WS, "src", "*", "test", "*.test"))) + \
    sorted(glob.glob(os.path.join(WS, "tests", "*.test")))


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


LONG_BELOW_SPEED = 2.0  # a .test whose simulator runs slower than this takes minutes


def simulator_speed(path):
    """The simulator speed a .test sets (<arg name="speed" value|default="X"/>), or None."""
    with open(path) as f:
        m = re.search(r'<arg\s+name="speed"\s+(?:value|default)="([0-9.]+)"', f.read())
    return float(m.group(1)) if m else None


def rostest_param(path):
    speed = simulator_speed(path)
    long = speed is not None and speed < LONG_BELOW_SPEED
    return pytest.param(path, id=case_id(path), marks=[pytest.mark.long] if long else [])


@pytest.mark.integration
@pytest.mark.parametrize("test_file", [rostest_param(p) for p in TEST_FILES])
def test_rostest(test_file, tmp_path):
    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path / "log"), ROS_HOME=str(tmp_path))
    rc, out = run_bounded(rostest_command(test_file), env, TIMEOUT)
    # The whole output beside the nodes' logs: the failure message below shows only its
    # end, and pytest keeps the last runs' tmp_path for a look after the fact.
    (tmp_path / "rostest.out").write_text(out)
    if rc is None:
        pytest.fail(f"rostest {test_file} did not finish within {TIMEOUT} s\n{out[-6000:]}")
    assert rc == 0 and "RESULT: SUCCESS" in out, out[-8000:]
    counts = [int(m) for m in re.findall(r"\* TESTS: (\d+)", out)]
    assert counts and counts[-1] > 0, "rostest ran no test case:\n" + out[-4000:]
