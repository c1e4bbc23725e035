"""The robot's geometry from its URDF: fixed joints and the laser's mounting pose.

Only fixed joints are read (the simplified Summit XL has no others); the simulator
publishes them as static transforms, casts its laser from the pose they give and takes
its IMU's lever arm from them.
"""
import math
import xml.etree.ElementTree as ET

import numpy as np


class DescriptionError(ValueError):
    """A URDF the simulator cannot use; the message names the file and the joint."""


def _floats(text, default, where):
    if text is None:
        return default
    try:
        vals = tuple(float(v) for v in text.split())
    except ValueError:
        raise DescriptionError(f"{where}: not numbers: {text!r}") from None
    if len(vals) != 3:
        raise DescriptionError(f"{where}: expected 3 numbers, got {text!r}")
    return vals


def fixed_joints(urdf_text, source="URDF"):
    """[(parent, child, (x, y, z), (roll, pitch, yaw))] of every fixed joint."""
    try:
        root = ET.fromstring(urdf_text)
    except ET.ParseError as e:
        raise DescriptionError(f"{source}: malformed XML: {e}") from None
    joints = []
    for j in root.iter("joint"):
        if j.get("type") != "fixed":
            continue
        name = j.get("name")
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None:
            raise DescriptionError(f"{source}: joint '{name}' lacks parent or child")
        origin = j.find("origin")
        xyz = _floats(origin.get("xyz") if origin is not None else None, (0.0, 0.0, 0.0), f"{source}: joint '{name}' xyz")
        rpy = _floats(origin.get("rpy") if origin is not None else None, (0.0, 0.0, 0.0), f"{source}: joint '{name}' rpy")
        joints.append((parent.get("link"), child.get("link"), xyz, rpy))
    return joints


def _matrix(xyz, rpy):
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    m = np.eye(4)
    m[:3, :3] = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                 [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                 [-sp, cp * sr, cp * cr]]
    m[:3, 3] = xyz
    return m


def frame_pose(joints, root, frame, source="URDF"):
    """4x4 transform of ``frame`` in ``root`` through the fixed-joint chain."""
    parent_of = {child: (parent, xyz, rpy) for parent, child, xyz, rpy in joints}
    m = np.eye(4)
    cur = frame
    while cur != root:
        if cur not in parent_of:
            raise DescriptionError(f"{source}: no chain of fixed joints from '{root}' to '{frame}'")
        parent, xyz, rpy = parent_of[cur]
        m = _matrix(xyz, rpy) @ m
        cur = parent
    return m


def level_mount(joints, base, frame, source="URDF"):
    """(x, y, yaw) of ``frame`` in ``base``; DescriptionError when it is not mounted level."""
    m = frame_pose(joints, base, frame, source)
    z_axis = m[:3, 2]
    if abs(z_axis[2] - 1.0) > 1e-6:
        raise DescriptionError(f"{source}: '{frame}' is not mounted level (z axis {z_axis.round(3)})")
    return float(m[0, 3]), float(m[1, 3]), math.atan2(m[1, 0], m[0, 0])


def laser_mount(joints, base="base_footprint", laser="hokuyo_base_link", source="URDF"):
    """(x, y, yaw) of the laser in the base frame; DescriptionError when not level."""
    return level_mount(joints, base, laser, source)


def imu_mount(joints, base="base_footprint", imu="imu_link", source="URDF"):
    """(x, y, yaw) of the IMU in the base frame (its lever arm and heading); DescriptionError
    when it is missing or not level (the simulated IMU is for a robot on level ground)."""
    return level_mount(joints, base, imu, source)
