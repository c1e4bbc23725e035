"""Summit XL model: kinematics with acceleration limits, command watchdog, odometry drift.

Kinematics (Siegwart & Nourbakhsh, Introduction to Autonomous Mobile Robots, ch. 3):
- ``diff``: skid steer treated as a differential drive, body velocity (vx, 0, wz);
  a commanded linear.y is ignored.
- ``omni``: mecanum wheels, body velocity (vx, vy, wz).
Each step moves the body velocity toward the command by at most the acceleration limit
times dt, then integrates the pose along the arc (midpoint heading).

Odometry, by model (``ODOM_MODELS``):

- ``ideal``: the increments the robot really made, in its own frame, plus zero-mean
  Gaussian noise whose *variance* grows with the motion (a random walk per metre and per
  radian, so the drift does not depend on the step size), plus an optional constant yaw
  scale error (``noisy_increment``). The twist reports the true velocity.
- ``skid`` (the default for ``diff``): the same noise, and the heading the wheels give
  overestimates every rotation by a factor k = 1 + a0 + a1 |wz| + s(t)
  (``skid_yaw_scale``). A skid-steer base turns by dragging its wheels sideways; the
  wheels' speed difference over the nominal track gives more rotation than the body
  makes. Mandow et al. 2007 ("Experimental kinematics for wheeled skid-steer mobile
  robots", IROS) measured that the instantaneous centres of rotation of the wheel
  treads lie well outside the wheels (an "ICR expansion factor" 1.5-2 on a Pioneer
  3-AT); odometry calibrated with an effective track width removes the mean of that
  (Martinez et al. 2005, "Approximating kinematics for tracked mobile robots", IJRR,
  the ICR model with fitted track) but not its dependence on the turn: the lateral
  friction that sets the ICRs grows with the centripetal load, so a fast turn slips more
  (Yi et al. 2009, IEEE T-RO, "Kinematic modeling and analysis of skid-steered mobile
  robots ...", slip grows with the turn rate). Residual after calibration, as modelled:
  a0 = 2.5 % on a slow turn (the calibration done on one floor and load, used on another),
  a1 = 2 % per rad/s, and s(t) a first-order Gauss-Markov process (sigma 1 %, correlation
  time 20 s: floor and tyre changes along the way) drawn from its own generator. The
  twist reports the wheels' view, (vx, vy, k wz): an EKF fusing it sees the same error
  as one fusing the pose. No lateral slip is modelled: ground truth keeps the
  differential-drive kinematics.

Seeded generators are passed in.
"""
import math
from dataclasses import dataclass

import numpy as np

from summit_nav_common.geometry import wrap_angle

ODOM_MODELS = ("ideal", "skid")
MIN_ODOM_VARIANCE = 1e-6   # floor of a reported variance: an EKF must never read "exact" [unit^2]


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
    # Skid-steer odometry (odom_model skid): measured / true rotation = 1 + a0 + a1 |wz| + s(t).
    skid_yaw_scale: float = 0.025            # a0 [-]: overestimate on a slow turn
    skid_yaw_scale_per_radps: float = 0.02   # a1 [1/(rad/s)]: growth with the turn rate
    skid_yaw_scale_sd: float = 0.01          # sigma of s(t) [-], stationary
    skid_yaw_scale_tau: float = 20.0         # correlation time of s(t) [s]

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


def _drifted_increment(params, inc, yaw_scale, rng):
    """A true body increment with the drift noise (three draws of rng) and its rotation
    measured ``yaw_scale`` times too large."""
    dx, dy, dth = inc
    trans = math.hypot(dx, dy)
    rot = abs(dth)
    if trans == 0.0 and rot == 0.0:
        return inc
    sd_trans = params.odom_trans_noise * math.sqrt(trans)
    sd_rot = math.sqrt(params.odom_rot_noise ** 2 * rot + params.odom_rot_per_trans ** 2 * trans)
    e = rng.standard_normal(3)
    scale = 1.0 + e[0] * sd_trans / trans if trans > 0.0 else 1.0
    return (dx * scale, dy * scale, dth * yaw_scale + e[2] * sd_rot)


def noisy_increment(params, inc, rng):
    """Odometry's view of a true body increment: drift noise and yaw scale error."""
    return _drifted_increment(params, inc, 1.0 + params.odom_yaw_scale_error, rng)


def skid_yaw_scale(params, wz, s):
    """Measured / true rotation of skid-steer odometry at turn rate wz [rad/s], with the
    slowly varying part s [-] (skid_scale_step); see the module docstring."""
    return 1.0 + params.odom_yaw_scale_error + params.skid_yaw_scale + params.skid_yaw_scale_per_radps * abs(wz) + s


def gauss_markov_step(x, dt, sd, tau, z):
    """One exact step of a first-order Gauss-Markov process (stationary sigma ``sd``,
    correlation time ``tau`` [s]) over dt [s], driven by standard normal draws z; works
    on floats and numpy arrays alike."""
    phi = math.exp(-dt / tau)
    return phi * x + sd * math.sqrt(1.0 - phi * phi) * z


def skid_scale_step(params, s, dt, rng):
    """The slowly varying part s of the skid yaw scale after dt [s] (one draw of rng)."""
    if params.skid_yaw_scale_sd <= 0.0:
        return 0.0
    return gauss_markov_step(s, dt, params.skid_yaw_scale_sd, params.skid_yaw_scale_tau, rng.standard_normal())


def skid_increment(params, inc, wz, s, rng):
    """Skid-steer odometry's view of a true body increment (dx, dy, dth) made at turn
    rate wz [rad/s]: noisy_increment's noise (the same three draws of rng) with the yaw
    scale skid_yaw_scale(params, wz, s) in place of the constant one."""
    return _drifted_increment(params, inc, skid_yaw_scale(params, wz, s), rng)


def skid_twist(params, vel, s):
    """The wheels' view of the body velocity (vx, vy, wz): the rotation rate scaled as
    the odometry's rotation is (skid_yaw_scale), the translation as driven."""
    return (vel[0], vel[1], vel[2] * skid_yaw_scale(params, vel[2], s))


def skid_twist_covariance(params, vel):
    """Diagonal variances (vx, vy, wz) [m^2/s^2, rad^2/s^2] of skid_twist's error as an
    estimator that knows the model but not the floor sees it: the yaw scale's whole
    excess (a0 + a1 |wz|, unknown in sign to it) and s(t)'s spread on wz; the translation
    noise per metre (odom_trans_noise) over one second of driving on vx and vy."""
    vx, vy, wz = vel
    excess = params.odom_yaw_scale_error + params.skid_yaw_scale + params.skid_yaw_scale_per_radps * abs(wz)
    var_wz = (excess ** 2 + params.skid_yaw_scale_sd ** 2) * wz * wz
    speed = math.hypot(vx, vy)
    var_v = params.odom_trans_noise ** 2 * speed
    return max(var_v, MIN_ODOM_VARIANCE), max(var_v, MIN_ODOM_VARIANCE), max(var_wz, MIN_ODOM_VARIANCE)


def skid_pose_budget_step(params, budget, inc, wz):
    """Accumulate the error budget of skid odometry's pose over one true increment inc
    (dx, dy, dth) at turn rate wz. budget = (white variance of x and y [m^2], white
    variance of yaw [rad^2], systematic yaw sd [rad], path length [m]); start (0, 0, 0, 0).
    The white parts grow as noisy_increment's random walks; the yaw scale's excess and
    spread add their sd linearly (one unknown scale for the whole run)."""
    white_xy, white_yaw, sys_yaw, dist = budget
    trans, rot = math.hypot(inc[0], inc[1]), abs(inc[2])
    excess = params.odom_yaw_scale_error + params.skid_yaw_scale + params.skid_yaw_scale_per_radps * abs(wz)
    return (white_xy + params.odom_trans_noise ** 2 * trans,
            white_yaw + params.odom_rot_noise ** 2 * rot + params.odom_rot_per_trans ** 2 * trans,
            sys_yaw + math.sqrt(excess ** 2 + params.skid_yaw_scale_sd ** 2) * rot,
            dist + trans)


def skid_pose_covariance(budget):
    """Diagonal variances (x, y, yaw) [m^2, m^2, rad^2] of skid odometry's pose from its
    budget (skid_pose_budget_step): a heading error that grew along the path of length D
    moves the position sideways by about half of it times D (variance var_yaw D^2 / 4)."""
    white_xy, white_yaw, sys_yaw, dist = budget
    var_yaw = white_yaw + sys_yaw ** 2
    var_xy = white_xy + var_yaw * dist * dist / 4.0
    return max(var_xy, MIN_ODOM_VARIANCE), max(var_xy, MIN_ODOM_VARIANCE), max(var_yaw, MIN_ODOM_VARIANCE)
