"""Laser mounting geometry: from the laser's 3D pose in the base frame to planar beams.

gmapping (slam_gmapping.cpp, initMapper) accepts a laser whose scan plane is parallel to
the floor, upright or upside down: the laser's z axis, seen in the base frame, must be
(0, 0, +-1) within LEVEL_TOLERANCE. An upside-down laser sweeps its beams the other way,
which is handled here by turning each beam direction into the base frame, so the SLAM
core always gets beam angles in a frame with the base's orientation.
"""
import numpy as np

LEVEL_TOLERANCE = 0.001  # gmapping's test: | |up_z| - 1 | must stay below this [-] (~2.6 deg tilt)


def is_level(rotation):
    """True when the laser's scan plane is parallel to the base's x-y plane (upright or
    upside down), with gmapping's tolerance. rotation: 3x3 laser->base matrix."""
    return abs(abs(float(rotation[2, 2])) - 1.0) < LEVEL_TOLERANCE


def beam_angles_in_base(rotation, angle_min, angle_increment, n_beams):
    """Directions (n,) [rad] of the beams in the base frame's orientation.

    Beam k points along angle_min + k * angle_increment in the laser frame; its direction
    rotated into the base frame and projected on the floor gives the result (yaw + angle
    for an upright laser, yaw - angle for one upside down).
    """
    a = angle_min + angle_increment * np.arange(int(n_beams))
    dx = rotation[0, 0] * np.cos(a) + rotation[0, 1] * np.sin(a)
    dy = rotation[1, 0] * np.cos(a) + rotation[1, 1] * np.sin(a)
    return np.arctan2(dy, dx)
