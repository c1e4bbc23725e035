"""Message conversions of the amcl node (no rospy: message classes only, unit-tested).

amcl_node.cpp's message handling, written once: the initialpose checks
(``handleInitialPoseMessage``: the pose must be in the global frame; an empty frame_id is
accepted with a warning; a non-finite pose is ignored), the 6x6 covariance layout of
PoseWithCovariance (row-major over x, y, z, roll, pitch, yaw; amcl fills the x/y block
and yaw*yaw), the particle cloud (built as one array: PoseArrayBlock; pose_array_msg,
one Pose per particle, is its reference), the map->odom transform, the laser's pose in the base
frame, and the beam angles of a LaserScan.

Poses are (x [m], y [m], yaw [rad]) numpy arrays.
"""
import math
import struct

import numpy as np
from geometry_msgs.msg import Pose, PoseArray, PoseWithCovarianceStamped, TransformStamped
from std_msgs.msg import Header

from summit_nav_common.geometry import quaternion_to_yaw, yaw_to_quaternion_zw

# Indices of the 6x6 row-major covariance (x, y, z, roll, pitch, yaw).
I_XX, I_XY, I_YX, I_YY, I_AA = 0, 1, 6, 7, 35
I_XA, I_YA, I_AX, I_AY = 5, 11, 30, 31
SYMMETRY_TOL = 1e-9     # |cov - cov^T| allowed in an initialpose [m^2, rad^2]


class InitialPoseError(ValueError):
    """An initialpose to ignore; the message says why."""


def initial_pose_from_msg(msg, global_frame_id):
    """(mean (3,), cov (3, 3), warning or None) of a PoseWithCovarianceStamped.

    InitialPoseError when the frame is another than global_frame_id (amcl ignores it),
    or a value is NaN / infinite, or the x, y, yaw covariance is not symmetric positive
    semi-definite. An empty frame_id is taken as the global frame with a warning, as amcl
    does. Leading slashes are ignored when comparing frames (tf2 ignores them).
    """
    frame = msg.header.frame_id.lstrip("/")
    warning = None
    if not frame:
        warning = ("initialpose has an empty frame_id; taken as the global frame "
                   f"'{global_frame_id}' (always give a frame_id)")
    elif frame != global_frame_id.lstrip("/"):
        raise InitialPoseError(f"initialpose in frame '{msg.header.frame_id}' ignored: initial "
                               f"poses must be in the global frame '{global_frame_id}'")
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    values = [p.x, p.y, p.z, q.x, q.y, q.z, q.w] + list(msg.pose.covariance)
    if not all(math.isfinite(v) for v in values):
        raise InitialPoseError("initialpose ignored: it contains NaN or infinite values")
    if q.x == q.y == q.z == q.w == 0.0:
        raise InitialPoseError("initialpose ignored: its orientation is the zero quaternion")
    c = msg.pose.covariance
    cov = np.array([[c[I_XX], c[I_XY], c[I_XA]],
                    [c[I_YX], c[I_YY], c[I_YA]],
                    [c[I_AX], c[I_AY], c[I_AA]]], dtype=np.float64)
    if not np.allclose(cov, cov.T, atol=SYMMETRY_TOL):
        raise InitialPoseError("initialpose ignored: its covariance is not symmetric")
    evals = np.linalg.eigvalsh(cov)
    if evals.min() < -SYMMETRY_TOL * max(1.0, float(evals.max())):
        raise InitialPoseError("initialpose ignored: its covariance is not positive semi-definite "
                               f"(x, y, yaw eigenvalues {np.round(evals, 6).tolist()})")
    mean = np.array([p.x, p.y, quaternion_to_yaw(q)])
    return mean, cov, warning


def covariance_6x6(cov):
    """Row-major 36-list of a (3, 3) x, y, yaw covariance, as amcl fills amcl_pose."""
    out = [0.0] * 36
    out[I_XX], out[I_XY], out[I_YX], out[I_YY] = cov[0][0], cov[0][1], cov[1][0], cov[1][1]
    out[I_AA] = cov[2][2]
    out[I_XA], out[I_AX], out[I_YA], out[I_AY] = cov[0][2], cov[2][0], cov[1][2], cov[2][1]
    return [float(v) for v in out]


def pose_msg(pose):
    """geometry_msgs/Pose of (x, y, yaw)."""
    msg = Pose()
    msg.position.x, msg.position.y = float(pose[0]), float(pose[1])
    msg.orientation.z, msg.orientation.w = yaw_to_quaternion_zw(float(pose[2]))
    return msg


def pose_with_covariance_msg(pose, cov, frame_id, stamp=None):
    """PoseWithCovarianceStamped (amcl_pose) of a pose and its (3, 3) covariance."""
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = frame_id
    if stamp is not None:
        msg.header.stamp = stamp
    msg.pose.pose = pose_msg(pose)
    msg.pose.covariance = covariance_6x6(cov)
    return msg


def pose_array_msg(particles, frame_id, stamp=None):
    """PoseArray (particlecloud) of (N, 3) particles."""
    msg = PoseArray()
    msg.header.frame_id = frame_id
    if stamp is not None:
        msg.header.stamp = stamp
    p = np.asarray(particles, dtype=np.float64)
    qz, qw = np.sin(p[:, 2] / 2.0), np.cos(p[:, 2] / 2.0)
    poses = []
    for x, y, z, w in zip(p[:, 0].tolist(), p[:, 1].tolist(), qz.tolist(), qw.tolist()):
        m = Pose()
        m.position.x, m.position.y = x, y
        m.orientation.z, m.orientation.w = z, w
        poses.append(m)
    msg.poses = poses
    return msg


class PoseArrayBlock:
    """geometry_msgs/PoseArray (particlecloud) of (N, 3) particles, without a Pose object
    per particle: the poses are kept as the (N, 7) float64 block (x, y, z, qx, qy, qz, qw)
    that is their wire layout, and serialize() writes it in one copy. Publish it on a
    PoseArray publisher (rospy matches a message to the topic by md5sum). Same bytes as
    pose_array_msg(particles, frame_id, stamp).serialize()."""

    _type, _md5sum, _full_text = PoseArray._type, PoseArray._md5sum, PoseArray._full_text
    _has_header = True
    __slots__ = ("header", "block")

    def __init__(self, particles, frame_id, stamp=None):
        p = np.asarray(particles, dtype=np.float64)
        self.header = Header(frame_id=frame_id) if stamp is None else Header(frame_id=frame_id, stamp=stamp)
        self.block = np.zeros((p.shape[0], 7), "<f8")
        self.block[:, :2] = p[:, :2]
        self.block[:, 5] = np.sin(p[:, 2] / 2.0)
        self.block[:, 6] = np.cos(p[:, 2] / 2.0)

    def serialize(self, buff):
        self.header.serialize(buff)
        buff.write(struct.pack("<I", self.block.shape[0]))
        buff.write(self.block.tobytes())


def transform_msg(pose, parent, child, stamp=None):
    """TransformStamped parent -> child of (x, y, yaw) (e.g. map -> odom)."""
    msg = TransformStamped()
    msg.header.frame_id = parent
    msg.child_frame_id = child
    if stamp is not None:
        msg.header.stamp = stamp
    msg.transform.translation.x, msg.transform.translation.y = float(pose[0]), float(pose[1])
    msg.transform.rotation.z, msg.transform.rotation.w = yaw_to_quaternion_zw(float(pose[2]))
    return msg


def pose_of_transform(transform):
    """(x, y, yaw) of a geometry_msgs/Transform (z, roll and pitch ignored)."""
    t, q = transform.translation, transform.rotation
    return np.array([t.x, t.y, quaternion_to_yaw(q)])


def pose_of_pose_msg(pose):
    """(x, y, yaw) of a geometry_msgs/Pose."""
    return np.array([pose.position.x, pose.position.y, quaternion_to_yaw(pose.orientation)])


def scan_angles(angle_min, angle_increment, n):
    """(n,) beam angles [rad] of a LaserScan in the laser frame."""
    return angle_min + angle_increment * np.arange(n, dtype=np.float64)
