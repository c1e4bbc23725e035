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


def test_drift_is_probabilistic_robotics_rot1_trans_rot2():
    # straight 1 m steps along x: with translation noise only, every noisy step stays on
    # the direction of travel (rot1 = rot2 = 0 exactly): no lateral error, no heading error
    ref = np.column_stack((np.arange(200.0), np.zeros(200), np.zeros(200)))
    odom = carmen.make_drifted_odometry(ref, np.random.default_rng(3), trans_per_trans=0.1,
                                        trans_per_rot=0.0, rot_per_trans=0.0, rot_per_rot=0.0)
    assert_allclose(odom[:, 1:], 0.0, atol=1e-12)
    steps = np.diff(odom[:, 0])
    assert np.std(steps) == pytest.approx(0.1, rel=0.15) and np.mean(steps) == pytest.approx(1.0, abs=0.03)
    # heading noise per metre only: rot1 and rot2 each get std 0.02 rad, the step's
    # heading change std 0.02 * sqrt(2); the step length stays 1 m
    odom = carmen.make_drifted_odometry(ref, np.random.default_rng(4), trans_per_trans=0.0,
                                        trans_per_rot=0.0, rot_per_trans=0.02, rot_per_rot=0.0)
    inc = carmen.relative_increments(odom)
    assert_allclose(np.hypot(inc[:, 0], inc[:, 1]), 1.0, atol=1e-12)
    assert np.std(inc[:, 2]) == pytest.approx(0.02 * math.sqrt(2), rel=0.15)
    # a turn in place with translation noise per radian: the base moves along its heading
    # (rot1 = 0 when there is no direction of travel), never sideways
    turn = np.column_stack((np.zeros(100), np.zeros(100), carmen.wrap_angle(0.3 * np.arange(100))))
    odom = carmen.make_drifted_odometry(turn, np.random.default_rng(5), trans_per_trans=0.0,
                                        trans_per_rot=0.1, rot_per_trans=0.0, rot_per_rot=0.0)
    inc = carmen.relative_increments(odom)
    assert_allclose(inc[:, 1], 0.0, atol=1e-12)
    assert np.std(inc[:, 0]) == pytest.approx(0.1 * 0.3, rel=0.2)
    # driving backwards is not a half turn: its rotation noise is that of a straight step
    back = ref[::-1].copy()
    odom = carmen.make_drifted_odometry(back, np.random.default_rng(6), 0.0, 0.0, 0.0, rot_per_rot=0.5)
    assert_allclose(odom, back, atol=1e-9)


def test_read_carmen_laser_offset_and_bad_files(tmp_path):
    path = str(tmp_path / "off.log")
    with open(path, "w") as f:
        f.write("PARAM robot_frontlaser_offset 0.25 nohost 0\nFLASER 2 1.0 2.0 0 0 0 0 0 0 1.0 h 1.0\n")
    assert carmen.read_carmen(path).laser_offset == 0.25
    with pytest.raises(FileNotFoundError):
        carmen.read_carmen(str(tmp_path / "missing.log.gz"))
    trunc = tmp_path / "trunc.log.gz"
    trunc.write_bytes(open(INTEL, "rb").read()[:5000])
    with pytest.raises(ValueError, match=f"{trunc}: not a readable CARMEN log"):
        carmen.read_carmen(str(trunc))
