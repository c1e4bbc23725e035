"""geometry: SE(2) algebra against hand-computed cases, broadcasting, and quaternions."""
import math
import os

import numpy as np
import pytest
from numpy.testing import assert_allclose

from summit_nav_common import files, geometry as g


def test_wrap_angle_range_and_types():
    assert g.wrap_angle(math.pi) == pytest.approx(-math.pi)
    assert g.wrap_angle(-math.pi) == pytest.approx(-math.pi)
    assert g.wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert isinstance(g.wrap_angle(7.0), float)
    a = g.wrap_angle(np.linspace(-20, 20, 101))
    assert a.min() >= -math.pi and a.max() < math.pi
    assert_allclose(np.sin(a), np.sin(np.linspace(-20, 20, 101)), atol=1e-12)
    assert_allclose(g.wrap_angle([0.0, 2 * math.pi + 0.5]), [0.0, 0.5], atol=1e-12)
    assert g.angle_diff(0.1, 2 * math.pi - 0.1) == pytest.approx(0.2)


def test_compose_by_hand():
    # Robot at (1, 2) facing +y; a point 1 m ahead and 0.5 m to its left is at (0.5, 3).
    assert_allclose(g.compose((1.0, 2.0, math.pi / 2), (1.0, 0.5, 0.25)), (0.5, 3.0, math.pi / 2 + 0.25),
                    atol=1e-12)


def test_inverse_relative_and_broadcasting():
    rng = np.random.default_rng(4)
    a = rng.uniform(-5, 5, (50, 3))
    b = rng.uniform(-5, 5, (50, 3))
    assert_allclose(g.compose(a, g.inverse(a)), np.zeros((50, 3)), atol=1e-12)
    assert_allclose(g.compose(a, g.relative(a, b)), np.column_stack([b[:, :2], g.wrap_angle(b[:, 2])]),
                    atol=1e-12)
    one = g.compose(a[0], b)                       # (3,) with (N, 3)
    assert one.shape == (50, 3)
    assert_allclose(one[7], g.compose(a[0], b[7]), atol=1e-12)
    out = a.copy()
    g.compose(out, b, out=out)                     # in place, as the particle filters do
    assert_allclose(out, g.compose(a, b), atol=1e-12)


def test_transform_points():
    pts = g.transform_points([[1.0, 0.0], [0.0, 1.0]], (2.0, 3.0, math.pi / 2))
    assert_allclose(pts, [[2.0, 4.0], [1.0, 3.0]], atol=1e-12)


def test_quaternions():
    z, w = g.yaw_to_quaternion_zw(2.5)
    assert g.yaw_of_quaternion(0.0, 0.0, z, w) == pytest.approx(2.5)
    q = type("Q", (), {"x": 0.0, "y": 0.0, "z": z, "w": w})()
    assert g.quaternion_to_yaw(q) == pytest.approx(2.5)
    r = g.quaternion_matrix(0.0, 0.0, 2 * z, 2 * w)      # normalized first
    assert_allclose(r[:2, :2], [[math.cos(2.5), -math.sin(2.5)], [math.sin(2.5), math.cos(2.5)]], atol=1e-12)
    with pytest.raises(ValueError, match="not a rotation"):
        g.quaternion_matrix(0, 0, 0, 0)


def test_write_atomic_replaces_whole_or_keeps_old(tmp_path):
    p = tmp_path / "f.txt"
    files.write_atomic(p, "one\n")
    files.write_atomic(p, b"two\n")
    assert p.read_text() == "two\n"
    assert os.stat(p).st_mode & 0o777 == 0o666 & ~_umask()
    with pytest.raises(OSError):
        files.write_atomic(tmp_path / "missing" / "f.txt", "x")
    assert sorted(os.listdir(tmp_path)) == ["f.txt"]       # no temporary file left behind


def _umask():
    m = os.umask(0)
    os.umask(m)
    return m


def test_pose_error_is_the_distance_and_the_wrapped_yaw_difference():
    d, a = g.pose_error((1.0, 1.0, math.pi - 0.1), (4.0, 5.0, -math.pi + 0.1))
    assert d == pytest.approx(5.0) and a == pytest.approx(0.2)
    assert isinstance(a, float) and g.pose_error((0.0, 0.0, 0.3), (0.0, 0.0, 0.3)) == (0.0, 0.0)
