"""Summit XL model: kinematics with acceleration limits, command watchdog, odometry drift.

Kinematics (Siegwart & Nourbakhsh, Introduction to Autonomous Mobile Robots, ch. 3):
- ``diff``: skid steer treated as a differential drive, body velocity (vx, 0, wz);
  a commanded linear.y is ignored.
- ``omni``: mecanum wheels, body velocity (vx, vy, wz).
Each step moves the body velocity toward the command by at most the acceleration limit
times dt, then integrates the pose along the arc (midpoint heading).

Odometry: the increments the robot really made, in its own frame, plus zero-mean
Gaussian noise whose *variance* grows with the motion (a random walk per metre and per
radian, so the drift does not depend on the step size), plus an optional systematic yaw
scale error, the usual failing of skid-steer odometry. Seeded generator passed in.
"""
import math
from dataclasses import dataclass

import numpy as np

from summit_nav_common.geometry import wrap_angle


@dataclass
class RobotParams:
    """Physical parameters of the simulated Summit XL (defaults: the real robot's)."""

    length: float = 0.72          # footprint along x [m]
    width: float = 0.62           # footprint along y [m]
    max_vel_x: float = 1.5        # [m/s]
    max_vel_y: float = 1.5        # [m/s] (omni only)
    max_vel_theta: float = 3.0    # [rad/s]
    acc_lim_x: float = 2.5        # [m/s^2]
    acc_lim_y: float = 2.5        # [m/s^2] (omni only)
    acc_lim_theta: float = 5.0    # [rad/s^2]
    cmd_timeout: float = 0.25     # watchdog: no command for this long -> stop [s]
    # Odometry drift: standard deviations per sqrt of the motion.
    odom_trans_noise: float = 0.01     # [m / sqrt(m)] translation error per metre driven
    odom_rot_noise: float = 0.01       # [rad / sqrt(rad)] heading error per radian turned
    odom_rot_per_trans: float = 0.005  # [rad / sqrt(m)] heading error per metre driven
    odom_yaw_scale_error: float = 0.0  # systematic relative error of measured turning [-]

    @property
    def circumradius(self):
        """Radius [m] of the circle through the footprint corners."""
        return math.hypot(self.length, self.width) / 2.0

    def footprint(self):
        """Footprint polygon (4, 2) [m] in base_footprint, as costmap_2d expects."""
        hl, hw = self.length / 2.0, self.width / 2.0
        return np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])


def footprint_samples(params, spacing):
    """Points (N, 2) [m] covering the footprint (edges and interior) every ``spacing``."""
    nx = max(2, int(math.ceil(params.length / spacing)) + 1)
    ny = max(2, int(math.ceil(params.width / spacing)) + 1)
    xs = np.linspace(-params.length / 2.0, params.length / 2.0, nx)
    ys = np.linspace(-params.width / 2.0, params.width / 2.0, ny)
    gx, gy = np.meshgrid(xs, ys)
    return np.column_stack([gx.ravel(), gy.ravel()])


def _approach(v, target, max_delta):
    if target > v:
        return min(target, v + max_delta)
    return max(target, v - max_delta)


def sanitize_command(params, drive, vx, vy, wz):
    """Clamp a commanded body velocity to the limits.

    Returns (vx, vy, wz, problem): ``problem`` is None for a usable command, or a text
    saying why it was rejected (NaN or inf), in which case the velocities are None.
    """
    if not all(math.isfinite(v) for v in (vx, vy, wz)):
        return None, None, None, f"non-finite velocity ({vx}, {vy}, {wz})"
    vx = max(-params.max_vel_x, min(params.max_vel_x, vx))
    vy = max(-params.max_vel_y, min(params.max_vel_y, vy)) if drive == "omni" else 0.0
    wz = max(-params.max_vel_theta, min(params.max_vel_theta, wz))
    return vx, vy, wz, None


def step_velocity(params, vel, cmd, dt):
    """Body velocity (vx, vy, wz) after dt [s] of acceleration-limited tracking of cmd."""
    return (_approach(vel[0], cmd[0], params.acc_lim_x * dt),
            _approach(vel[1], cmd[1], params.acc_lim_y * dt),
            _approach(vel[2], cmd[2], params.acc_lim_theta * dt))


def integrate_pose(pose, vel, dt):
    """Pose (x, y, yaw) after moving with body velocity vel for dt [s] (midpoint rule)."""
    x, y, yaw = pose
    vx, vy, wz = vel
    mid = yaw + 0.5 * wz * dt
    c, s = math.cos(mid), math.sin(mid)
    return (x + (vx * c - vy * s) * dt, y + (vx * s + vy * c) * dt, wrap_angle(yaw + wz * dt))


def noisy_increment(params, inc, rng):
    """Odometry's view of a true body increment: drift noise and yaw scale error."""
    dx, dy, dth = inc
    trans = math.hypot(dx, dy)
    rot = abs(dth)
    if trans == 0.0 and rot == 0.0:
        return inc
    sd_trans = params.odom_trans_noise * math.sqrt(trans)
    sd_rot = math.sqrt(params.odom_rot_noise ** 2 * rot + params.odom_rot_per_trans ** 2 * trans)
    e = rng.standard_normal(3)
    scale = 1.0 + e[0] * sd_trans / trans if trans > 0.0 else 1.0
    return (dx * scale, dy * scale,
            dth * (1.0 + params.odom_yaw_scale_error) + e[2] * sd_rot)
