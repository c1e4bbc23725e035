"""Sensor messages -> EKF measurements, as robot_localization's ekf_localization_node
prepares them (no rospy: arrays in, ekf.Measurement out).

Each configured sensor (odomN, imuN, poseN, twistN) keeps a SensorState: its 15-bool
`_config` mask, `_differential` (absolute pose turned into body-frame velocity by
differencing consecutive poses: delta = prev^-1 cur, twist = delta / dt, covariance
(prev + cur) rotated into the previous body frame, times dt, as robot_localization
documents and does), `_relative` (poses taken relative to the sensor's first one),
rejection thresholds, and for an IMU the removal of gravity. An IMU's data are rotated
from its frame (imu_link) into the body frame with the mounting rotation R_base_imu:
orientation R_world_base = R_world_imu R_base_imu^T, rates and accelerations
R_base_imu v, covariances R C R^T (robot_localization ignores the lever arm too).
A pose in another frame than the world frame comes with the transform world <- frame.
"""
import math
from dataclasses import dataclass

import numpy as np

from summit_nav_common.geometry import euler_from_matrix

from .ekf import STATE_SIZE, Measurement, rotation

POSE = slice(0, 6)     # x y z roll pitch yaw
TWIST = slice(6, 12)   # vx vy vz vroll vpitch vyaw
ACCEL = slice(12, 15)  # ax ay az
STANDARD_GRAVITY = 9.80665   # [m/s^2] robot_localization's gravitational_acceleration default


def matrix_from_quaternion(q):
    """Rotation matrix of a quaternion (x, y, z, w) (normalized here); None when its norm
    is 0 or not finite."""
    q = np.asarray(q, dtype=np.float64)
    n = float(np.dot(q, q))
    if not math.isfinite(n) or n < 1e-12:
        return None
    x, y, z, w = q / math.sqrt(n)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def transform(pose6):
    """4x4 homogeneous transform of (x, y, z, roll, pitch, yaw)."""
    t = np.eye(4)
    t[:3, :3] = rotation(*pose6[3:6])
    t[:3, 3] = pose6[0:3]
    return t


def pose6(t):
    """(x, y, z, roll, pitch, yaw) of a 4x4 transform."""
    return np.array(list(t[:3, 3]) + list(euler_from_matrix(t[:3, :3])))


def invert(t):
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def rotate6(cov, r):
    """A 6x6 (linear, angular) covariance rotated by R: blockdiag(R, R) C blockdiag(R, R)^T."""
    b = np.zeros((6, 6))
    b[:3, :3] = r
    b[3:, 3:] = r
    return b @ cov @ b.T


@dataclass
class SensorState:
    """One configured sensor and what it remembers between messages.

    name: its parameter prefix (odom0, imu0, ...); topic; config: the 15-bool mask;
    thresholds [Mahalanobis distance]: pose, twist, angular_velocity,
    linear_acceleration (inf: no rejection)."""
    name: str
    topic: str
    config: np.ndarray
    differential: bool = False
    relative: bool = False
    pose_threshold: float = math.inf
    twist_threshold: float = math.inf
    angular_velocity_threshold: float = math.inf
    linear_acceleration_threshold: float = math.inf
    remove_gravitational_acceleration: bool = False
    gravity: float = STANDARD_GRAVITY
    prev_pose: np.ndarray = None          # differential: (4x4, cov 6x6, stamp)
    first_pose: np.ndarray = None         # relative: the first pose's 4x4

    def __post_init__(self):
        # The measurement masks each message of this sensor gets, made once from config
        # (15 bools): part name -> (15,) bool, its state indices set where config selects.
        self.config = np.asarray(self.config, dtype=bool)
        c = self.config
        self.masks = {name: _part_mask(dest, c[src]) for name, dest, src in (
            ("pose", POSE, POSE), ("pose_differential", TWIST, POSE), ("twist", TWIST, TWIST),
            ("orientation", slice(3, 6), slice(3, 6)), ("orientation_differential", slice(9, 12), slice(3, 6)),
            ("angular_velocity", slice(9, 12), slice(9, 12)), ("linear_acceleration", ACCEL, ACCEL))}
        self.uses_pose, self.uses_twist = bool(c[POSE].any()), bool(c[TWIST].any())
        self.uses_orientation, self.uses_angular_velocity = bool(c[3:6].any()), bool(c[9:12].any())
        self.uses_acceleration = bool(c[ACCEL].any())

    def reset(self):
        """Forget the previous pose (differential) and the first one (relative), as
        set_pose does."""
        self.prev_pose = None
        self.first_pose = None


def _part_mask(dest, flags):
    mask = np.zeros(STATE_SIZE, dtype=bool)
    mask[dest] = flags
    mask.flags.writeable = False     # shared by every measurement of its sensor
    return mask


def _measurement(stamp, values, mask, threshold, source):
    z = np.full(STATE_SIZE, np.nan)
    c = np.zeros((STATE_SIZE, STATE_SIZE))
    for sl, v, cv in values:
        z[sl] = v
        c[sl, sl] = cv
    return Measurement(stamp, z, c, mask, threshold, source)


def pose_measurement(s: SensorState, stamp, pose, cov, world_from_frame=None):
    """The measurement a pose message of sensor s gives, or None (nothing to fuse yet: a
    differential sensor's first pose).

    pose: (x, y, z, roll, pitch, yaw) in the message's frame; cov: its 6x6 covariance;
    world_from_frame: 4x4 transform world <- that frame (None: it is the world frame).
    The pose part of s.config selects; in differential mode the same flags select the
    velocities (vx for x, ...)."""
    cov = np.asarray(cov, dtype=np.float64).reshape(6, 6)
    t = transform(np.asarray(pose, dtype=np.float64))
    if world_from_frame is not None:
        t = world_from_frame @ t
        cov = rotate6(cov, world_from_frame[:3, :3])
    if s.relative:
        if s.first_pose is None:
            s.first_pose = t.copy()
        r0 = s.first_pose[:3, :3]
        t = invert(s.first_pose) @ t
        cov = rotate6(cov, r0.T)
    if s.differential:
        prev, s.prev_pose = s.prev_pose, (t, cov, stamp)
        if prev is None:
            return None
        t_prev, cov_prev, stamp_prev = prev
        dt = stamp - stamp_prev
        if not dt > 0.0:
            return None
        delta = pose6(invert(t_prev) @ t)
        r_prev_t = t_prev[:3, :3].T
        twist_cov = (rotate6(cov_prev, r_prev_t) + rotate6(cov, r_prev_t)) * dt
        return _measurement(stamp, [(TWIST, delta / dt, twist_cov)], s.masks["pose_differential"],
                            s.pose_threshold, s.topic)
    return _measurement(stamp, [(POSE, pose6(t), cov)], s.masks["pose"], s.pose_threshold, s.topic)


def twist_measurement(s: SensorState, stamp, twist, cov, base_from_frame=None):
    """The measurement a twist (vx, vy, vz, vroll, vpitch, vyaw) of sensor s gives, in its
    message's frame; base_from_frame: 3x3 rotation base <- that frame (None: it is the
    body frame)."""
    twist = np.asarray(twist, dtype=np.float64)
    cov = np.asarray(cov, dtype=np.float64).reshape(6, 6)
    if base_from_frame is not None:
        twist = np.concatenate([base_from_frame @ twist[:3], base_from_frame @ twist[3:]])
        cov = rotate6(cov, base_from_frame)
    return _measurement(stamp, [(TWIST, twist, cov)], s.masks["twist"], s.twist_threshold, s.topic)


def _provided(cov):
    """False when a sensor_msgs/Imu covariance (9 values or 3x3) says its part is not
    provided: element 0 is -1."""
    return float(np.ravel(cov)[0]) != -1.0


def imu_measurements(s: SensorState, stamp, orientation, orientation_cov, angular_velocity, angular_velocity_cov,
                     linear_acceleration, linear_acceleration_cov, base_from_imu=None):
    """The measurements an IMU message of sensor s gives (a list: orientation, angular
    velocity, linear acceleration, each with its own threshold), rotated from the IMU's
    frame into the body frame by base_from_imu (3x3; None: identity). A part whose
    covariance[0] is -1 (sensor_msgs/Imu: not provided) is left out, as is an
    orientation whose quaternion is zero."""
    r_bi = None if base_from_imu is None else np.asarray(base_from_imu, dtype=np.float64)
    out = []
    # the orientation, when a part uses it: the orientation's own, or gravity's removal
    needs_orientation = s.uses_orientation or (s.uses_acceleration and s.remove_gravitational_acceleration)
    r_wi = matrix_from_quaternion(orientation) if needs_orientation and _provided(orientation_cov) else None
    if r_wi is not None and s.uses_orientation:
        r_bi = np.eye(3) if r_bi is None else r_bi
        ocov = np.asarray(orientation_cov, dtype=np.float64).reshape(3, 3)
        r_wb = r_wi @ r_bi.T
        ori = np.array(euler_from_matrix(r_wb))
        ori_cov = r_bi @ ocov @ r_bi.T
        if s.relative:
            if s.first_pose is None:
                s.first_pose = r_wb.copy()
            ori = np.array(euler_from_matrix(s.first_pose.T @ r_wb))
        if s.differential:
            prev, s.prev_pose = s.prev_pose, (ori, ori_cov, stamp)
            if prev is not None and stamp > prev[2]:
                dt = stamp - prev[2]
                r_prev = rotation(*prev[0])
                delta = np.array(euler_from_matrix(r_prev.T @ rotation(*ori)))
                out.append(_measurement(stamp, [(slice(9, 12), delta / dt, (prev[1] + ori_cov) * dt)],
                                        s.masks["orientation_differential"], s.pose_threshold, s.topic))
        else:
            out.append(_measurement(stamp, [(slice(3, 6), ori, ori_cov)], s.masks["orientation"], s.pose_threshold,
                                    s.topic))
    if s.uses_angular_velocity and _provided(angular_velocity_cov):
        w = np.asarray(angular_velocity, dtype=np.float64)
        wcov = np.asarray(angular_velocity_cov, dtype=np.float64).reshape(3, 3)
        if r_bi is not None:    # None: the IMU's frame is the body frame
            w, wcov = r_bi @ w, r_bi @ wcov @ r_bi.T
        out.append(_measurement(stamp, [(slice(9, 12), w, wcov)], s.masks["angular_velocity"],
                                s.angular_velocity_threshold, s.topic))
    if s.uses_acceleration and _provided(linear_acceleration_cov):
        r_bi = np.eye(3) if r_bi is None else r_bi
        acov = np.asarray(linear_acceleration_cov, dtype=np.float64).reshape(3, 3)
        a = np.asarray(linear_acceleration, dtype=np.float64)
        if s.remove_gravitational_acceleration:
            # gravity as the IMU feels it (an upward specific force), in the IMU's frame
            up = np.array([0.0, 0.0, s.gravity])
            a = a - (r_wi.T @ up if r_wi is not None else up)
        out.append(_measurement(stamp, [(ACCEL, r_bi @ a, r_bi @ acov @ r_bi.T)], s.masks["linear_acceleration"],
                                s.linear_acceleration_threshold, s.topic))
    return out


def odometry_measurements(s: SensorState, stamp, pose, pose_cov, twist, twist_cov, world_from_frame=None,
                          base_from_child=None):
    """nav_msgs/Odometry: its pose part (pose_measurement) and twist part
    (twist_measurement), each when s.config selects any of it."""
    out = []
    if s.uses_pose:
        m = pose_measurement(s, stamp, pose, pose_cov, world_from_frame)
        if m is not None:
            out.append(m)
    if s.uses_twist:
        out.append(twist_measurement(s, stamp, twist, twist_cov, base_from_child))
    return out
