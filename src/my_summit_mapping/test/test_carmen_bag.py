"""CARMEN log -> rosbag: beams, no-return readings, drift, stamps, frames; bad input."""
import gzip
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import rosbag
from numpy.testing import assert_allclose

from my_summit_mapping import carmen, carmen_bag, metrics

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "scripts", "carmen_to_bag.py")
INTEL = os.path.join(HERE, "..", "..", "..", "data", "carmen", "intel-corrected.log.gz")
NO_RETURN = 81.83


def _flaser(n, ranges, pose, stamp):
    return (f"FLASER {n} " + " ".join(f"{r:g}" for r in ranges) + f" {pose[0]} {pose[1]} {pose[2]} "
            f"{pose[0]} {pose[1]} {pose[2]} {stamp} pippo {stamp}")


def _write_log(path, n=180, stamps=(10.0, 10.5, 11.2, 11.1, 12.0), offset=0.0):
    """A small log: scan k has beam j = 1 + 0.01 j + k, beam 5 no return; the robot
    drives 0.3 m and turns 0.1 rad per scan."""
    lines = ["# CARMEN log", f"PARAM robot_frontlaser_offset {offset} nohost 0"]
    for k, t in enumerate(stamps):
        r = 1.0 + 0.01 * np.arange(n) + k
        r[5] = NO_RETURN
        lines.append("ODOM 0 0 0 0 0 0 0.0 pippo 0.0")
        lines.append(_flaser(n, r, (0.3 * k, 0.02 * k * k, 0.1 * k), t))
    with gzip.open(path, "wt") as f:
        f.write("\n".join(lines) + "\n")


@pytest.mark.parametrize("n, last_deg", [(180, 89.0), (181, 90.0)])
def test_beam_geometry_and_no_return(tmp_path, n, last_deg):
    path = str(tmp_path / "mini.log.gz")
    _write_log(path, n=n)
    s = carmen_bag.bag_scans(carmen.read_carmen(path), seed=0)
    assert s.angle_min == pytest.approx(-math.pi / 2)
    assert s.angle_increment == pytest.approx(math.pi / 180)
    assert s.angle_min + (n - 1) * s.angle_increment == pytest.approx(math.radians(last_deg))
    assert s.range_max == NO_RETURN                          # the log's no-return reading
    assert np.all(np.isinf(s.ranges[:, 5])) and np.all(np.isfinite(np.delete(s.ranges, 5, axis=1)))
    assert_allclose(s.ranges[2, :5], 3.0 + 0.01 * np.arange(5))


def test_stamps_are_the_logs_made_increasing(tmp_path):
    path = str(tmp_path / "mini.log.gz")
    _write_log(path)
    s = carmen_bag.bag_scans(carmen.read_carmen(path), seed=0)
    assert_allclose(s.stamps, [10.0, 10.5, 11.2, 11.2 + carmen_bag.MIN_STAMP_GAP, 12.0])
    assert s.stamps_moved == 1


def test_drift_is_seeded_repeatable_and_starts_at_the_reference():
    """Same seed, same drift to 1e-9 m; not bit for bit. One CI run in a pytest-xdist worker
    under load (cf2a858) got two seed-1 drifts that were not array_equal, which 30 repeats
    in one process on an idle machine did not reproduce; the SLAM filter's own runs differ
    by ~1e-15 m the same way (docs/slam.md). The cause is not found; a different seed
    gives metres of difference."""
    log = carmen.read_carmen(INTEL)
    a = carmen_bag.bag_scans(log, seed=1)
    b = carmen_bag.bag_scans(log, seed=1)
    c = carmen_bag.bag_scans(log, seed=2)
    assert_allclose(a.odometry, b.odometry, rtol=0.0, atol=1e-9)
    assert not np.allclose(a.odometry, c.odometry)
    assert_allclose(a.odometry[0], log.poses[0])
    assert_allclose(a.reference, log.poses)
    assert_allclose(a.odometry, carmen.make_drifted_odometry(
        log.poses, np.random.default_rng(1 + carmen_bag.ODOM_SEED_OFFSET)))
    assert metrics.ate_rmse(a.odometry, a.reference) > 0.5   # real drift over 2650 s


def test_bag_messages_frames_stamps_and_bytes(tmp_path):
    path = str(tmp_path / "mini.log.gz")
    _write_log(path, offset=0.12)
    s = carmen_bag.bag_scans(carmen.read_carmen(path), seed=4)
    bag1, bag2, bag3 = (str(tmp_path / f"{k}.bag") for k in ("a", "b", "c"))
    carmen_bag.write_bag(s, bag1)
    carmen_bag.write_bag(carmen_bag.bag_scans(carmen.read_carmen(path), seed=4), bag2)
    carmen_bag.write_bag(carmen_bag.bag_scans(carmen.read_carmen(path), seed=5), bag3)
    with open(bag1, "rb") as f1, open(bag2, "rb") as f2, open(bag3, "rb") as f3:
        b1, b2, b3 = f1.read(), f2.read(), f3.read()
    assert b1 == b2 and b1 != b3
    with rosbag.Bag(bag1) as bag:
        msgs = list(bag.read_messages(return_connection_header=True))
    static = [m for m in msgs if m.topic == "/tf_static"]
    assert len(static) == 1 and static[0].connection_header["latching"] == b"1"
    mount = static[0].message.transforms[0]
    assert (mount.header.frame_id, mount.child_frame_id) == ("base_link", "base_laser")
    assert mount.transform.translation.x == pytest.approx(0.12) and mount.transform.rotation.w == 1.0
    assert static[0].timestamp.to_sec() == pytest.approx(10.0 - carmen_bag.STATIC_LEAD)
    scans = [m for m in msgs if m.topic == "/scan"]
    assert [m.message.header.stamp.to_sec() for m in scans] == pytest.approx(s.stamps.tolist())
    assert all(m.timestamp == m.message.header.stamp for m in scans)
    first = scans[0].message
    assert first.header.frame_id == "base_laser" and len(first.ranges) == 180
    assert first.range_max == pytest.approx(NO_RETURN) and first.range_min == 0.0
    assert math.isinf(first.ranges[5]) and first.ranges[0] == pytest.approx(1.0)
    # every scan's odometry tf comes before it, at its stamp
    order = [m.topic for m in msgs if m.topic != "/tf_static"]
    assert order == ["/tf", "/scan", "/reference_pose"] * len(s.stamps)
    tfs = [m.message.transforms[0] for m in msgs if m.topic == "/tf"]
    assert {(t.header.frame_id, t.child_frame_id) for t in tfs} == {("odom", "base_link")}
    back = carmen_bag.read_bag(bag1)
    assert_allclose(back.odometry, s.odometry, atol=1e-9)
    assert_allclose(back.reference, s.reference, atol=1e-9)
    assert_allclose(back.stamps, s.stamps, atol=1e-6)
    assert back.laser_offset == pytest.approx(0.12) and back.range_max == pytest.approx(NO_RETURN)
    assert np.array_equal(np.isinf(back.ranges), np.isinf(s.ranges))


def _convert(*args):
    return subprocess.run([sys.executable, SCRIPT] + list(args), stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True)


def test_converter_script_writes_the_bag(tmp_path):
    path = str(tmp_path / "mini.log.gz")
    _write_log(path)
    out = str(tmp_path / "mini.bag")
    r = _convert(path, out, "--seed", "3")
    assert r.returncode == 0, r.stderr
    assert "5 scans x 180 beams" in r.stdout and len(carmen_bag.read_bag(out).stamps) == 5


@pytest.mark.parametrize("kind", ["not_carmen", "truncated_gzip", "not_gzip", "missing"])
def test_converter_bad_input_names_the_file_and_fails(tmp_path, kind):
    path = tmp_path / f"{kind}.log.gz"
    if kind == "not_carmen":
        with gzip.open(path, "wt") as f:
            f.write("# just a text file\nODOM 0 0 0 0 0 0 0.1 h 0.1\n")
        expect = "no FLASER lines"
    elif kind == "truncated_gzip":
        data = open(INTEL, "rb").read()
        path.write_bytes(data[:len(data) // 3])
        expect = "not a readable CARMEN log"
    elif kind == "not_gzip":
        path.write_bytes(b"\x00\x01 not gzip at all" * 10)
        expect = "not a readable CARMEN log"
    else:
        expect = "No such file"
    out = tmp_path / "out.bag"
    r = _convert(str(path), str(out))
    assert r.returncode == 2
    assert str(path) in r.stderr and expect in r.stderr and "Traceback" not in r.stderr


def test_as_received_is_exactly_what_the_bag_gives_back(tmp_path):
    """The live node's inputs, bit for bit, without a bag: the filter is chaotic, and a
    replay of ACES seed 1 fed the log's float64 values ended at an online ATE of 0.868 m
    where the live run (and a replay of its bag) gave 0.422 m."""
    path = str(tmp_path / "mini.log.gz")
    _write_log(path, stamps=(10.123456789, 10.5, 11.2, 11.1, 12.7), offset=0.12)
    s = carmen_bag.bag_scans(carmen.read_carmen(path), seed=4)
    bag = str(tmp_path / "mini.bag")
    carmen_bag.write_bag(s, bag)
    back, got = carmen_bag.read_bag(bag), carmen_bag.as_received(s)
    for name in ("stamps", "ranges", "odometry", "reference"):
        assert np.array_equal(getattr(got, name), getattr(back, name)), name
    for name in ("angle_min", "angle_increment", "range_max", "laser_offset"):
        assert getattr(got, name) == getattr(back, name), name
    assert not np.array_equal(got.ranges, s.ranges)          # 1.01 m etc. are not float32 numbers
    assert_allclose(got.ranges, s.ranges, rtol=1e-7)
    assert got.seed == s.seed and got.stamps_moved == s.stamps_moved
