"""Runs every rostest .test file of the workspace, one pytest case each (the files and
the command: tools/rostest_files.py, on pytest's pythonpath)."""
import os
import re

import pytest

from rostest_files import TEST_FILES, TIMEOUT, case_id, is_long, rostest_command
from summit_nav_common.testing.roslaunch_session import run_bounded


def rostest_param(path):
    return pytest.param(path, id=case_id(path), marks=[pytest.mark.long] if is_long(path) else [])


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
