"""Laser mounting: level check with gmapping's tolerance, beam directions in the base frame."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_mapping import laser_mount
from summit_nav_common.geometry import quaternion_from_euler, quaternion_matrix


def test_upright_laser_adds_its_yaw():
    rot = quaternion_matrix(*quaternion_from_euler(0.0, 0.0, 0.4))
    assert laser_mount.is_level(rot)
    angles = laser_mount.beam_angles_in_base(rot, -2.0, 0.5, 9)
    expected = 0.4 + (-2.0 + 0.5 * np.arange(9))
    assert_allclose(angles, np.arctan2(np.sin(expected), np.cos(expected)), atol=1e-12)


def test_upside_down_laser_mirrors_the_beams():
    rot = quaternion_matrix(*quaternion_from_euler(math.pi, 0.0, 0.0))
    assert laser_mount.is_level(rot)
    angles = laser_mount.beam_angles_in_base(rot, -1.0, 0.25, 9)
    assert_allclose(angles, -(-1.0 + 0.25 * np.arange(9)), atol=1e-12)


@pytest.mark.parametrize("roll, pitch, level", [(0.0, 0.03, True), (0.0, 0.06, False),
                                                (0.1, 0.0, False), (math.pi / 2, 0.0, False)])
def test_level_tolerance_is_gmappings(roll, pitch, level):
    # gmapping: | |up_z| - 1 | < 0.001, i.e. about 2.6 degrees of tilt
    assert laser_mount.is_level(quaternion_matrix(*quaternion_from_euler(roll, pitch, 0.0))) is level


def test_zero_quaternion_is_an_error():
    with pytest.raises(ValueError, match="not a rotation"):
        quaternion_matrix(0, 0, 0, 0)
