"""Unit tests of fake_localization's arithmetic (no ROS master)."""
import math

import numpy as np
import pytest

from my_summit_localization.fake_localization import FakeLocalizer, offset_from_deltas
from my_summit_localization.particle_filter import compose


def test_without_offset_map_pose_is_the_truth_and_map_odom_closes_the_chain():
    loc = FakeLocalizer()
    truth = np.array([9.5, 14.5, math.radians(28.166)])
    odom = np.array([0.3, -0.1, 0.05])          # odometry has drifted
    pose, m2o = loc.update(truth, odom)
    np.testing.assert_allclose(pose, truth)
    np.testing.assert_allclose(compose(m2o, odom), truth, atol=1e-12)


def test_deltas_move_the_map_origin_like_fake_localization():
    # delta: the map origin at (1, 2) in the simulator's frame, not rotated: a truth at
    # (1, 2) is the map's origin.
    loc = FakeLocalizer(offset_from_deltas(1.0, 2.0, 0.0))
    pose, _ = loc.update([1.0, 2.0, 0.3], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(pose, [0.0, 0.0, 0.3], atol=1e-12)
    # delta_yaw rotates after the translation (tf::Transform(rot(-dyaw), -d) * truth)
    loc = FakeLocalizer(offset_from_deltas(1.0, 0.0, math.pi / 2))
    pose, _ = loc.update([2.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(pose, [-1.0, -2.0, -math.pi / 2], atol=1e-12)


def test_initialpose_rebases_the_offset_and_later_motion_follows():
    loc = FakeLocalizer()
    loc.update([5.0, 5.0, 0.0], [0.0, 0.0, 0.0])
    loc.set_pose([1.0, 1.0, math.pi / 2])
    # the robot drives 1 m forward in truth: in the new frame it moves along +y
    pose, m2o = loc.update([6.0, 5.0, 0.0], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(pose, [1.0, 2.0, math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(compose(m2o, [1.0, 0.0, 0.0]), pose, atol=1e-12)


def test_errors():
    loc = FakeLocalizer()
    with pytest.raises(ValueError, match="no ground-truth pose"):
        loc.set_pose([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="non-finite"):
        loc.update([math.nan, 0.0, 0.0], [0.0, 0.0, 0.0])
    loc.update([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="non-finite"):
        loc.set_pose([0.0, math.inf, 0.0])
