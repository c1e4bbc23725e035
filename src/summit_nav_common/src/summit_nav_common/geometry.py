"""Angles, SE(2) poses and quaternions: the small geometry every package uses.

A pose is (x [m], y [m], yaw [rad]); functions take one pose as a length-3 sequence or
many as an (N, 3) array and broadcast like numpy. ``compose(a, b)`` is a (+) b
(Lu & Milios 1997; Smith, Self & Cheeseman 1990): b, given in a's frame, expressed in a's
parent frame. Angles are wrapped to [-pi, pi).
"""
import math

import numpy as np

TWO_PI = 2.0 * math.pi


def wrap_angle(a):
    """Angle(s) [rad] wrapped into [-pi, pi); a float stays a float, an array an array."""
    if isinstance(a, (list, tuple)):
        a = np.asarray(a, dtype=np.float64)
    return (a + math.pi) % TWO_PI - math.pi


def angle_diff(a, b):
    """Smallest signed difference a - b [rad], in [-pi, pi)."""
    return wrap_angle(np.asarray(a) - np.asarray(b) if isinstance(a, (list, tuple)) else a - b)


def pose_error(a, b):
    """(distance [m], |yaw difference| [rad]) between two poses (x, y, yaw), as floats:
    how far an estimate is from the truth, or a robot from its goal."""
    return math.hypot(a[0] - b[0], a[1] - b[1]), abs(float(wrap_angle(a[2] - b[2])))


def compose(a, b, out=None):
    """Pose(s) a (+) b: b expressed in a's frame, returned in a's parent frame.

    a, b: (3,) or (N, 3) [m, m, rad], broadcast against each other; out: optional
    preallocated result (may be a or b). Returns a float64 array.
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    th = wrap_angle(a[..., 2] + b[..., 2])
    if out is None:
        out = np.empty(np.broadcast(a, b).shape)
    out[..., 0], out[..., 1], out[..., 2] = x, y, th
    return out


def inverse(a):
    """Inverse pose(s) of a: compose(a, inverse(a)) is the identity."""
    a = np.asarray(a, dtype=np.float64)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([-c * a[..., 0] - s * a[..., 1], s * a[..., 0] - c * a[..., 1],
                     wrap_angle(-a[..., 2])], axis=-1)


def relative(origin, pose):
    """pose seen from origin: inverse(origin) (+) pose, e.g. the motion from origin to pose
    in origin's frame."""
    o = np.asarray(origin, dtype=np.float64)
    p = np.asarray(pose, dtype=np.float64)
    c, s = np.cos(o[..., 2]), np.sin(o[..., 2])
    dx, dy = p[..., 0] - o[..., 0], p[..., 1] - o[..., 1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(p[..., 2] - o[..., 2])], axis=-1)


def transform_points(points, pose):
    """Points (N, 2) [m] given in the frame of pose (x, y, yaw) -> the pose's parent frame."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.asarray(points, dtype=np.float64) @ np.array([[c, s], [-s, c]]) + \
        np.array([pose[0], pose[1]])


def transform_points_3d(points, translation, quaternion):
    """Points (N, 3) [m] given in a frame -> its parent, the frame's pose there being
    translation (x, y, z) [m] and quaternion (x, y, z, w) (a tf TransformStamped's)."""
    return np.asarray(points, dtype=np.float64) @ quaternion_matrix(*quaternion).T + np.asarray(translation, float)


def yaw_to_quaternion_zw(yaw):
    """(z, w) of the unit quaternion of a rotation by yaw [rad] about z."""
    return math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def yaw_of_quaternion(x, y, z, w):
    """Yaw [rad] of the quaternion (x, y, z, w); roll and pitch are ignored."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def quaternion_to_yaw(q):
    """Yaw [rad] of a quaternion message (fields x, y, z, w, e.g. geometry_msgs/Quaternion)."""
    return yaw_of_quaternion(q.x, q.y, q.z, q.w)


def quaternion_matrix(x, y, z, w):
    """3x3 rotation matrix of a quaternion (x, y, z, w), normalized first; ValueError when
    it has no direction (zero or not finite)."""
    q = np.array([x, y, z, w], float)
    n = np.linalg.norm(q)
    if not np.isfinite(n) or n == 0.0:
        raise ValueError(f"quaternion {tuple(q)} is not a rotation")
    x, y, z, w = q / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def quaternion_from_euler(roll, pitch, yaw):
    """Quaternion (x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def euler_from_matrix(r):
    """(roll, pitch, yaw) [rad] of a rotation matrix R = Rz Ry Rx."""
    return (math.atan2(r[2, 1], r[2, 2]), -math.asin(max(-1.0, min(1.0, r[2, 0]))),
            math.atan2(r[1, 0], r[0, 0]))
