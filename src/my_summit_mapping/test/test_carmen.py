"""CARMEN reader and the drifted odometry."""
import gzip
import math
import os

import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_mapping import carmen, metrics

INTEL = os.path.join(os.path.dirname(__file__), "..", "..", "..", "data", "carmen",
                     "intel-corrected.log.gz")  # the workspace's data/


def _write_log(path, lines):
    with gzip.open(path, "wt") as f:
        f.write("# comment\nPARAM robot_frontlaser_offset 0.0 nohost 0\n")
        f.write("\n".join(lines) + "\n")


def test_reads_flaser_lines(tmp_path):
    path = str(tmp_path / "mini.log.gz")
    _write_log(path, ["ODOM 0 0 0 0 0 0 0.1 host 0.1",
                      "FLASER 4 1.0 2.0 3.0 4.0 0.5 0.6 0.7 9 9 9 12.5 host 12.6",
                      "FLASER 4 1.5 2.5 3.5 4.5 1.5 1.6 1.7 9 9 9 13.5 host 13.6"])
    log = carmen.read_carmen(path)
    assert_allclose(log.ranges, [[1, 2, 3, 4], [1.5, 2.5, 3.5, 4.5]])
    assert_allclose(log.poses, [[0.5, 0.6, 0.7], [1.5, 1.6, 1.7]])
    assert_allclose(log.timestamps, [12.5, 13.5])
    assert_allclose(log.angles, -math.pi / 2 + np.arange(4) * math.pi / 4)


def test_rejects_changed_beam_count(tmp_path):
    path = str(tmp_path / "bad.log.gz")
    _write_log(path, ["FLASER 2 1.0 2.0 0 0 0 0 0 0 1.0 h 1.0",
                      "FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 2.0 h 2.0"])
    with pytest.raises(ValueError, match="beam count changed"):
        carmen.read_carmen(path)


def test_beam_angles_span():
    assert_allclose(carmen.beam_angles(181)[[0, -1]], [-math.pi / 2, math.pi / 2])
    assert_allclose(np.diff(carmen.beam_angles(180)), math.pi / 180)


def test_reads_intel_log():
    log = carmen.read_carmen(INTEL)
    assert log.ranges.shape == (910, 180) and log.poses.shape == (910, 3)


def test_drift_is_seeded_and_grows_with_motion():
    t = np.linspace(0, 6 * np.pi, 300)
    ref = np.column_stack((5 * np.cos(t), 5 * np.sin(t), t + np.pi / 2))
    ref[:, 2] = carmen.wrap_angle(ref[:, 2])
    zero = carmen.make_drifted_odometry(ref, np.random.default_rng(0), 0, 0, 0, 0)
    assert_allclose(zero, ref, atol=1e-9)
    a = carmen.make_drifted_odometry(ref, np.random.default_rng(1))
    b = carmen.make_drifted_odometry(ref, np.random.default_rng(1))
    assert_allclose(a, b)
    assert_allclose(a[0], ref[0])
    assert metrics.ate_rmse(a, ref) > 0.05
    still = np.zeros((50, 3))
    assert_allclose(carmen.make_drifted_odometry(still, np.random.default_rng(2)), still)
