"""DWA local planner: the Dynamic Window Approach over a rolling local costmap.

Reference: Fox, Burgard & Thrun 1997, "The Dynamic Window Approach to Collision
Avoidance" (IEEE Robotics & Automation Magazine 4(1)); ROS 1 ``dwa_local_planner``
(DWAPlanner with base_local_planner's SimpleTrajectoryGenerator, MapGridCostFunction,
ObstacleCostFunction, OscillationCostFunction, TwirlingCostFunction and
LatchedStopRotateController); wiki.ros.org/dwa_local_planner for the parameters.

Every control period (DWAPlanner.compute_velocity) the planner searches the velocities
the robot can reach within one period for the one whose trajectory, held constant, best
follows the global plan without hitting anything. The pipeline, in the order it runs,
one function each, vectorized over all samples x steps:

1. ``dynamic_window``: the velocities reachable within sim_period = 1/controller_frequency
   [s] under acc_lim_x/y [m/s^2] and acc_lim_theta [rad/s^2], clipped to the limits.
2. ``sample_velocities``: vx_samples x vy_samples x vth_samples evenly over the window (0
   added when a range spans it, as base_local_planner's VelocityIterator), minus those
   faster than max_vel_trans [m/s] or slower than both min_vel_trans [m/s] and
   min_vel_theta [rad/s]; from rest, turns on the spot at min_vel_theta are added when
   the window does not reach it. In escape mode (``sampling_config``) slow reversing
   down to -ESCAPE_VEL_X is sampled too.
3. ``rollouts``: each sample held over sim_time [s] (scored) + stop_time_buffer [s]
   (checked), Euler steps of at most sim_granularity [m] / angular_sim_granularity
   [rad]: poses, the costmap cell under the centre and the footprint clearance of each.
4. Admissibility (Fox et al.'s admissible velocities): ``goal_approach`` picks the step
   each sample is scored at (heading for the final goal, a trajectory that gets within
   xy_goal_tolerance [m] is scored at its closest approach, where it would stop; all
   others at the end of sim_time) and flags samples too fast to stop at the goal;
   ``check_horizon`` gives the steps each must stay clear over (the whole horizon, or to
   its stop at the goal plus braking time, stop_time_buffer and the control latency).
   ``ordinary_admissibility`` rejects a sample whose footprint clearance drops below the
   ClearancePolicy's limit, whose centre meets an inscribed cell, that leaves the
   costmap, or that the oscillation flags forbid (a reversal of rotation, strafe or
   direction until the robot has moved oscillation_reset_dist [m] or turned
   oscillation_reset_angle [rad]). ``escape_admissibility`` applies when the robot
   starts inside its footprint_padding or on an inscribed cell, or when no ordinary
   sample is admissible: the ClearancePolicy's escape limits, slow moves judged only up
   to where they could stop, reversing only where it regains clearance.
5. ``scores``: dwa_local_planner's cost, distances in metres:
   0.5 path_distance_bias (distance to the plan of the scored point + of the point
   forward_point_distance [m] ahead of it) + 0.5 goal_distance_bias (distance to the
   local goal along the plan, of both points) + occdist_scale (highest costmap cost
   under the centre, ``obstacle_costs``) + twirling_scale |vth|. The forward point is
   measured against the plan from forward_point_distance ahead of the robot on, so a
   robot facing away from its plan turns toward it the short way (dwa_local_planner's
   grids reach the plan's first cells, where every backward heading scores the same).
6. ``choose``: the cheapest admissible sample; the oscillation flags are updated.
7. ``no_valid_reason``: with none admissible, how many samples each constraint rejected
   and where the nearest obstacle lies; move_base then stops the robot.

Footprint clearance (``footprint_clearance``, [m], negative inside the padded
footprint): the footprint is covered by circles (Footprint.covering_circles); a pose's
clearance is the least distance from a circle to a lethal or unknown cell centre
(bilinear lookup in the distance field) less its radius and half a cell, refined near
obstacles by the footprint's finer grid circles and its corners. ``ClearancePolicy`` says
how low that clearance may go: 0 normally, and the escape, creep, reversing, recovery
and goal-rotation limits, from the clearance now and footprint_padding [m].

Goal handling (LatchedStopRotateController): within xy_goal_tolerance [m] (latched with
latch_xy_goal_tolerance) the robot brakes within its acceleration limits while it
starts turning, turns on the spot to the goal heading on the time-optimal profile
(``rotation_speed``) until within yaw_goal_tolerance [rad], and reports the goal reached
once stopped (trans_stopped_vel [m/s], theta_stopped_vel [rad/s]). The goal approach
is planned with APPROACH_DECEL x acc_lim_x; move_base's measured control latency
(set_control_latency, [s]) lengthens braking and the checked horizon, and the goal
rotation plans each command for the time it stays in force.

Parameters (DWAConfig, the DWAPlannerROS namespace, Noetic names and defaults) carry
their units there; scaling_speed, max_scaling_factor and use_dwa are accepted and not
used (this planner always samples the dynamic window; move_base says so once, with the
values: plugins._dwa_planner).
"""
import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
from summit_nav_common.geometry import wrap_angle
from summit_nav_common.grid_kernels import chamfer_labels

from .clearance import ClearancePolicy, _nearest_blocked, footprint_checks, footprint_clearance, obstacle_distance
from .goal_approach import braked, rotation_speed
from .local_plan import DWAResult, HeldPlan
from .oscillation import OscillationFlags

EPS = 1e-5                 # velocity comparison slack [m/s or rad/s]
MAX_SIM_STEPS = 200        # cap on forward-simulation steps per trajectory [-]
BLOCK_BYTES = 192 * 1024   # a block of samples' float64 (rows, steps) array, at most (> 1 row)
NEAR_GOAL_FACTOR = 1.0     # forward-point terms off within this many forward_point_distance of the goal
PRUNE_SEARCH_ARC = 2.0     # [m] of plan searched ahead for the point nearest the robot (prunePlan)
MAX_LATENCY = 1.0          # [s] cap on the control latency braking plans for
ARRIVAL_TIME_WEIGHT = 0.01  # [1/s] x goal_distance_bias: prefer reaching the goal sooner
ESCAPE_VEL_X = 0.2         # [m/s] backing-up speed allowed in escape mode even when min_vel_x >= 0
NO_OBSTACLE_DIST = 1.0e6   # [m] distance field value when the costmap has no blocked cell
ALONG_PLAN_GAIN = 0.05     # [m] ... unless it gets this much nearer the goal along the plan


APPROACH_DECEL = 0.75     # x acc_lim_x: the deceleration the approach to the goal is planned with
GOAL_DEAD_ZONE = 0.5       # x xy_goal_tolerance: closest approaches this near the goal all count as arriving

# A latched xy goal is let go when the robot ends up farther than this many
# xy_goal_tolerance from it (it latched while passing at speed and coasted on) [-].
UNLATCH_FACTOR = 2.0


@dataclass
class DWAConfig:
    """dwa_local_planner's ROS parameters (DWAPlannerROS namespace), Noetic names."""

    max_vel_x: float = 0.55          # [m/s]
    min_vel_x: float = 0.0           # [m/s] negative allows reversing
    max_vel_y: float = 0.1           # [m/s] 0 for a diff drive
    min_vel_y: float = -0.1          # [m/s]
    max_vel_trans: float = 0.55      # [m/s] bound on |(vx, vy)|
    min_vel_trans: float = 0.1       # [m/s] slower translations need min_vel_theta rotation
    max_vel_theta: float = 1.0       # [rad/s]
    min_vel_theta: float = 0.4       # [rad/s]
    acc_lim_x: float = 2.5           # [m/s^2]
    acc_lim_y: float = 2.5           # [m/s^2]
    acc_lim_theta: float = 3.2       # [rad/s^2]
    acc_lim_trans: float = 0.0       # [m/s^2] accepted; 0 = not used
    trans_stopped_vel: float = 0.1   # [m/s] below this the robot counts as stopped
    theta_stopped_vel: float = 0.1   # [rad/s]
    xy_goal_tolerance: float = 0.10  # [m]
    yaw_goal_tolerance: float = 0.05  # [rad]
    latch_xy_goal_tolerance: bool = False
    sim_time: float = 1.7            # [s]
    sim_granularity: float = 0.025   # [m] step between simulated points
    angular_sim_granularity: float = 0.1  # [rad]
    vx_samples: int = 3
    vy_samples: int = 10
    vth_samples: int = 20
    controller_frequency: float = 20.0  # [Hz] sim_period = 1 / controller_frequency
    path_distance_bias: float = 32.0
    goal_distance_bias: float = 24.0
    occdist_scale: float = 0.01
    twirling_scale: float = 0.0
    forward_point_distance: float = 0.325  # [m]
    stop_time_buffer: float = 0.2    # [s] the trajectory must stay free this much longer
    scaling_speed: float = 0.25      # [m/s] accepted (footprint scaling: not used)
    max_scaling_factor: float = 0.2  # accepted (not used)
    oscillation_reset_dist: float = 0.05   # [m]
    oscillation_reset_angle: float = 0.2   # [rad]
    prune_plan: bool = True
    use_dwa: bool = True             # accepted; this planner always uses the dynamic window
    publish_traj_pc: bool = False
    publish_cost_grid_pc: bool = False
    holonomic_robot: bool = False    # base_local_planner name; True enables vy sampling

    @property
    def sim_period(self):
        """[s] one control period."""
        return 1.0 / self.controller_frequency

    @property
    def horizon(self):
        """[s] how long a sample is rolled out: sim_time + stop_time_buffer."""
        return self.sim_time + max(0.0, self.stop_time_buffer)


# -- 1. dynamic window ----------------------------------------------------------------
def dynamic_window(cfg, vel):
    """((vx_min, vx_max), (vy_min, vy_max), (vth_min, vth_max)) reachable in one sim_period."""
    dt = cfg.sim_period
    vx, vy, vth = vel
    wx = (max(cfg.min_vel_x, vx - cfg.acc_lim_x * dt), min(cfg.max_vel_x, vx + cfg.acc_lim_x * dt))
    wy = (max(cfg.min_vel_y, vy - cfg.acc_lim_y * dt), min(cfg.max_vel_y, vy + cfg.acc_lim_y * dt))
    wth = (max(-cfg.max_vel_theta, vth - cfg.acc_lim_theta * dt),
           min(cfg.max_vel_theta, vth + cfg.acc_lim_theta * dt))
    # A window entirely outside the limits (e.g. faster than max after a config change)
    # collapses onto the nearest limit.
    fix = lambda lo_hi, lo, hi: (min(max(lo_hi[0], lo), hi), max(min(lo_hi[1], hi), lo))
    return (fix(wx, cfg.min_vel_x, cfg.max_vel_x), fix(wy, cfg.min_vel_y, cfg.max_vel_y),
            fix(wth, -cfg.max_vel_theta, cfg.max_vel_theta))


def velocity_samples_1d(lo, hi, n):
    """base_local_planner's VelocityIterator: n even samples over [lo, hi], 0 inserted if spanned."""
    if hi - lo <= EPS:
        return np.array([lo])
    s = np.linspace(lo, hi, max(2, int(n)))
    if lo < 0.0 < hi and not np.any(np.abs(s) < EPS):
        s = np.sort(np.append(s, 0.0))
    return s


# -- 2. samples ----------------------------------------------------------------------
def sample_velocities(cfg, window, holonomic):
    """(N, 3) valid velocity samples (vx, vy, vth) of the window."""
    (x0, x1), (y0, y1), (t0, t1) = window
    vxs = velocity_samples_1d(x0, x1, cfg.vx_samples)
    vys = velocity_samples_1d(y0, y1, cfg.vy_samples) if holonomic else np.array([0.0])
    vts = velocity_samples_1d(t0, t1, cfg.vth_samples)
    g = np.stack(np.meshgrid(vxs, vys, vts, indexing="ij"), axis=-1).reshape(-1, 3)
    vmag = np.hypot(g[:, 0], g[:, 1])
    ok = vmag <= cfg.max_vel_trans + EPS
    too_slow = (vmag + EPS < cfg.min_vel_trans) & (np.abs(g[:, 2]) + EPS < cfg.min_vel_theta)
    g = g[ok & ~too_slow]
    if x0 <= EPS <= x1 + 2 * EPS and y0 <= EPS <= y1 + 2 * EPS and max(abs(t0), abs(t1)) + EPS < cfg.min_vel_theta:
        # From rest the window (acc_lim_theta x sim_period) may not reach min_vel_theta:
        # every in-place turn would be "too slow" and the robot could only drive forward;
        # facing an obstacle it could never turn away. Turning at min_vel_theta is what
        # the base accepts (rotate_recovery and the goal rotation command it as well).
        turns = np.array([[0.0, 0.0, -cfg.min_vel_theta], [0.0, 0.0, cfg.min_vel_theta]])
        g = np.vstack([g, turns]) if len(g) else turns
    return g


def sampling_config(cfg, escape):
    """The config the window and samples are drawn with: in escape mode slow reversing
    (down to -ESCAPE_VEL_X) is sampled too, even when min_vel_x >= 0."""
    return dataclasses.replace(cfg, min_vel_x=min(cfg.min_vel_x, -ESCAPE_VEL_X)) if escape else cfg


# -- 3. rollouts ----------------------------------------------------------------------
def simulation_steps(cfg, samples, horizon):
    """Number of Euler steps so that no sample moves more than the granularities per step."""
    if len(samples) == 0:
        return 1
    vmax = float(np.hypot(samples[:, 0], samples[:, 1]).max())
    wmax = float(np.abs(samples[:, 2]).max())
    n = max(vmax * horizon / cfg.sim_granularity, wmax * horizon / cfg.angular_sim_granularity, 1.0)
    return int(min(MAX_SIM_STEPS, math.ceil(n)))


def simulate(pose, samples, dt, n_steps):
    """Poses of every sample after each of n_steps Euler steps of dt [s].

    pose: (x, y, yaw); samples: (N, 3) body velocities. Returns x, y, yaw each (N, n_steps),
    step k holding the pose at time (k + 1) * dt (base_local_planner's computeNewPositions:
    translate with the heading at the start of the step, then turn).
    """
    x0, y0, th0 = pose
    vx, vy, w = samples[:, 0:1], samples[:, 1:2], samples[:, 2:3]
    k = np.arange(n_steps, dtype=np.float64)[None, :]
    th_before = th0 + w * (k * dt)
    c, s = np.cos(th_before), np.sin(th_before)
    x = x0 + np.cumsum((vx * c - vy * s) * dt, axis=1)
    y = y0 + np.cumsum((vx * s + vy * c) * dt, axis=1)
    return x, y, th_before + w * dt


@dataclass
class Rollouts:
    """The samples held constant over sim_time + stop_time_buffer, (N, T) arrays over
    samples x steps of dt [s] (the first n_score steps span sim_time): poses x, y [m],
    th [rad]; their cells mx, my, inside (on the costmap) and centre (the cost under the
    robot's centre, NO_INFORMATION off the map); clearance [m] (footprint_clearance);
    next_clear (N,) [m]: the clearance where the next control cycle starts (latency on)."""

    x: np.ndarray
    y: np.ndarray
    th: np.ndarray
    dt: float
    n_score: int
    mx: np.ndarray
    my: np.ndarray
    inside: np.ndarray
    centre: np.ndarray
    clearance: np.ndarray
    next_clear: np.ndarray

    @property
    def n_steps(self):
        return self.x.shape[1]


def rollouts(cfg, pose, samples, costmap, clearance, latency, n_steps):
    """Rollouts of samples (N, 3) from pose over n_steps steps of cfg.horizon; clearance(x,
    y, th) -> [m] of poses; latency [s]: how long this cycle's command stays in force.
    n_steps is the whole cycle's (simulation_steps of all its samples): these may be a
    block of them."""
    dt = cfg.horizon / n_steps
    n_score = max(1, min(n_steps, int(round(cfg.sim_time / dt))))
    x, y, th = simulate(pose, samples, dt, n_steps)
    h, w = costmap.data.shape
    mx = np.floor((x - costmap.origin_x) / costmap.resolution).astype(np.int64)
    my = np.floor((y - costmap.origin_y) / costmap.resolution).astype(np.int64)
    inside = (mx >= 0) & (my >= 0) & (mx < w) & (my < h)
    centre = np.where(inside, costmap.data[np.clip(my, 0, h - 1), np.clip(mx, 0, w - 1)], NO_INFORMATION)
    nx, ny, nth = simulate(pose, samples, latency, 1)
    return Rollouts(x, y, th, dt, n_score, mx, my, inside, centre, clearance(x, y, th),
                    clearance(nx[:, 0], ny[:, 0], nth[:, 0]))


# -- 4. admissibility -----------------------------------------------------------------
@dataclass
class Scene:
    """What a cycle plans in: the local costmap; dist_obs (H, W) [m]: distance to the
    nearest blocked cell (NO_OBSTACLE_DIST without one); dist_path, togo (H, W) [m]:
    path_distance_maps of the local plan; ahead_path, ahead_togo: the same of the local
    plan from forward_point_distance along it on (where the forward point is measured);
    local (M, 2): the local plan; plan: the global plan; final: the local plan ends at
    the goal."""

    costmap: object
    dist_obs: np.ndarray
    dist_path: np.ndarray
    togo: np.ndarray
    ahead_path: np.ndarray
    ahead_togo: np.ndarray
    local: np.ndarray
    plan: np.ndarray
    final: bool

    @property
    def goal(self):
        return self.plan[-1]

    def cells(self, x, y):
        """Costmap cells (clipped to the map) of points x, y [m]."""
        h, w = self.togo.shape
        res, cm = self.costmap.resolution, self.costmap
        mx = np.floor((x - cm.origin_x) / res).astype(np.int64)
        my = np.floor((y - cm.origin_y) / res).astype(np.int64)
        return my.clip(0, h - 1), mx.clip(0, w - 1)


def goal_approach(cfg, samples, ro, scene, dist_goal, v_now, latency):
    """(k, too_fast): the step each sample is scored at (N,) and the samples too fast to
    stop at the final goal (N,) bool.

    Off the final goal every sample is scored at the end of sim_time. Heading for it, a
    sample that gets within xy_goal_tolerance is scored at its closest approach (it would
    stop there), measured along the plan (plan length left + distance to it: a plan that
    winds round a wall first leads away from a goal near as the crow flies), the nearer
    in a straight line on ties; the others drive on and are scored at their end. A sample
    faster than the robot can stop from at APPROACH_DECEL x acc_lim_x before the goal
    (half the tolerance short, one latency of travel held back) is too fast.
    """
    rows = np.arange(len(samples))
    n_score = ro.n_score
    if not scene.final:
        return np.full(len(samples), n_score - 1), np.zeros(len(samples), dtype=bool)
    h, w = scene.togo.shape
    goal = scene.goal
    sx, sy = ro.mx[:, :n_score], ro.my[:, :n_score]
    dg = np.where(ro.inside[:, :n_score], scene.togo[sy.clip(0, h - 1), sx.clip(0, w - 1)]
                  + scene.dist_path[sy.clip(0, h - 1), sx.clip(0, w - 1)], np.inf)
    dg = dg + 1e-3 * np.hypot(ro.x[:, :n_score] - goal[0], ro.y[:, :n_score] - goal[1])
    k = np.argmin(dg, axis=1)
    arrives = np.hypot(ro.x[rows, k] - goal[0], ro.y[rows, k] - goal[1]) <= cfg.xy_goal_tolerance
    k = np.where(arrives, k, n_score - 1)
    room = dist_goal - 0.5 * cfg.xy_goal_tolerance - v_now * latency
    v_stop = math.sqrt(2.0 * APPROACH_DECEL * cfg.acc_lim_x * max(0.0, room))
    too_fast = np.hypot(samples[:, 0], samples[:, 1]) > max(v_stop, cfg.min_vel_trans) + EPS
    return k, too_fast


def check_horizon(cfg, samples, ro, k, final, latency):
    """(n_check, n_brake) (N,): the steps a sample's footprint must stay clear over, and
    those until it could stop (braking at the acceleration limits, plus stop_time_buffer
    and one latency). The whole horizon (sim_time + stop_time_buffer) as in
    dwa_local_planner; heading for the final goal, up to the scored step k plus n_brake."""
    t_brake = np.maximum(np.hypot(samples[:, 0], samples[:, 1]) / (2.0 * max(cfg.acc_lim_x, EPS)),
                         np.abs(samples[:, 2]) / (2.0 * max(cfg.acc_lim_theta, EPS)))
    n_brake = np.ceil((t_brake + max(0.0, cfg.stop_time_buffer) + latency) / ro.dt).astype(np.int64)
    if final:
        n_check = np.clip(k + 1 + n_brake, 1, ro.n_steps)
    else:
        n_check = np.full(len(samples), ro.n_steps)
    return n_check, n_brake


@dataclass
class Verdict:
    """Which samples (N,) bool are admissible (valid) and which constraint rejected the
    others (a sample may fail several); in escape mode also those boxed_in falls back on
    (backing, creeping)."""

    valid: np.ndarray
    collides: np.ndarray
    leaves: np.ndarray
    oscillates: np.ndarray
    too_fast: np.ndarray
    backing: np.ndarray = None
    creeping: np.ndarray = None

    @staticmethod
    def join(parts):
        """One Verdict of the blocks' Verdicts, in sample order."""
        return Verdict(*(None if getattr(parts[0], f.name) is None
                         else np.concatenate([getattr(p, f.name) for p in parts])
                         for f in dataclasses.fields(Verdict)))


def _lowest(clearance, until, next_clear):
    """(N,) the lowest clearance over the steps below until (N,) and at next_clear."""
    steps = np.arange(clearance.shape[1])[None, :]
    return np.minimum(np.where(steps < until[:, None], clearance, np.inf).min(axis=1), next_clear)


def _end_on_map(ro, k, costmap):
    """(N,) bool: the scored pose's cell lies on the costmap."""
    rows = np.arange(len(k))
    h, w = costmap.data.shape
    emx = np.floor((ro.x[rows, k] - costmap.origin_x) / costmap.resolution).astype(np.int64)
    emy = np.floor((ro.y[rows, k] - costmap.origin_y) / costmap.resolution).astype(np.int64)
    return (emx >= 0) & (emy >= 0) & (emx < w) & (emy < h)


def ordinary_admissibility(policy, ro, k, n_check, oscillates, too_fast, costmap):
    """dwa_local_planner's rule: the footprint keeps policy.normal clearance and the
    centre stays off inscribed cells over n_check steps, and on the costmap."""
    checked = np.arange(ro.n_steps)[None, :] < n_check[:, None]
    collides = (_lowest(ro.clearance, n_check, ro.next_clear) < policy.normal) | \
        ((ro.centre >= INSCRIBED_INFLATED_OBSTACLE) & ro.inside & checked).any(axis=1)
    leaves = (~ro.inside & checked).any(axis=1) | ~_end_on_map(ro, k, costmap)
    return Verdict(~(collides | leaves | oscillates | too_fast), collides, leaves, oscillates, too_fast)


def escape_admissibility(policy, floor, c0, v_now, samples, ro, k, n_check, n_brake, oscillates, too_fast,
                         scene, pose):
    """Escape mode's rule, from clearance c0 [m] with the clearance floor [m]; v_now
    [m/s]: the robot's speed when it is inside its padding (c0 < 0), else 0.

    A sample may not reach below policy.escape(floor) over n_check steps, nor touch a
    lethal cell with its centre. Moving forward or turning, it needs that only until it
    could stop (n_brake steps, Fox et al.'s admissible velocities) when it is slow (up to
    ESCAPE_VEL_X) and keeps policy.creep there, or, for a robot already driving faster,
    when it is no faster than now. Reversing must regain policy.back_out(c0) by the end
    of sim_time or end nearer the goal along the plan. Boxed in (nothing admissible),
    reversing that loses nothing is admitted, and failing that a slow reversing move
    that regains policy.creep_back(c0) by the time it could stop (boxed_in, over all the
    cycle's samples).
    """
    vx = samples[:, 0]
    rows = np.arange(len(samples))
    steps = np.arange(ro.n_steps)[None, :]
    lowest = policy.escape(floor)
    loses = _lowest(ro.clearance, n_check, ro.next_clear) < lowest
    speed = np.hypot(samples[:, 0], samples[:, 1])
    slow = speed <= ESCAPE_VEL_X + EPS
    driving = v_now > ESCAPE_VEL_X
    n_short = np.minimum(n_check, n_brake)
    short = steps < n_short[:, None]
    min_short = _lowest(ro.clearance, n_short, ro.next_clear)
    keeps_short = min_short >= policy.creep(floor, c0)
    passes = driving & (speed <= v_now + EPS) & (min_short >= lowest)
    crept = ((slow & keeps_short) | passes) & (vx >= 0.0) & loses
    creeps_back = slow & (vx < 0.0) & loses & keeps_short \
        & (ro.clearance[rows, np.clip(n_short - 1, 0, ro.n_steps - 1)] >= policy.creep_back(c0)) \
        & ~((ro.centre == LETHAL_OBSTACLE) & short).any(axis=1)
    loses &= ~crept
    checked = np.where(crept[:, None], short, steps < n_check[:, None])
    hits = ((ro.centre == LETHAL_OBSTACLE) & checked).any(axis=1)
    leaves = (~ro.inside & checked).any(axis=1) | ~_end_on_map(ro, k, scene.costmap)
    n = ro.n_score - 1
    along = _along_plan(scene.togo, scene.dist_path, scene.costmap, pose, ro.x[:, n], ro.y[:, n])
    collides = ~((vx >= 0.0) | (ro.clearance[:, n] >= policy.back_out(c0)) | along) | loses | hits
    valid = ~(collides | leaves | oscillates | too_fast)
    backing = (vx < 0.0) & ~(loses | hits) & ~(leaves | oscillates | too_fast)
    creeping = creeps_back & ~(leaves | oscillates | too_fast)
    return Verdict(valid, collides, leaves, oscillates, too_fast, backing, creeping)


def boxed_in(verdict):
    """Escape mode's fallback when none of the cycle's samples is admissible: reversing
    that loses no clearance, else creeping back (escape_admissibility)."""
    if verdict.valid.any():
        return verdict
    backing = verdict.backing if verdict.backing.any() else verdict.creeping
    if not backing.any():
        return verdict
    return dataclasses.replace(verdict, valid=backing, collides=verdict.collides & ~backing)


def _along_plan(togo, dist_path, costmap, pose, ex, ey, gain=ALONG_PLAN_GAIN):
    """(N,) bool: end points (ex, ey) [m] at least gain [m] nearer the goal along the
    plan (plan length left + distance to the plan) than the pose."""
    h, w = togo.shape
    res = costmap.resolution

    def along(px, py):
        mx = np.clip(np.floor((px - costmap.origin_x) / res).astype(np.int64), 0, w - 1)
        my = np.clip(np.floor((py - costmap.origin_y) / res).astype(np.int64), 0, h - 1)
        return togo[my, mx] + dist_path[my, mx]
    return along(np.asarray(ex), np.asarray(ey)) < along(np.array(pose[0]), np.array(pose[1])) - gain


# -- 5. scores ------------------------------------------------------------------------
def path_distance_maps(local, costmap):
    """Two (H, W) fields [m] over the costmap for a local plan (N, 2) [m]:
    distance to the nearest plan cell, and plan length left to the plan's end from that
    nearest plan cell. One chamfer distance transform with labels (OpenCV's
    distanceTransformWithLabels, DIST_MASK_5: grid_kernels.chamfer_labels).
    """
    res = costmap.resolution
    h, w = costmap.data.shape
    pts = np.asarray(local, dtype=np.float64)
    # Densify to half-cell spacing so every plan cell is drawn.
    seg = np.hypot(*np.diff(pts, axis=0).T) if len(pts) > 1 else np.zeros(0)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    total = arc[-1]
    n = max(2, int(math.ceil(total / (0.5 * res))) + 1)
    s = np.linspace(0.0, total, n)
    dense = np.column_stack([np.interp(s, arc, pts[:, 0]), np.interp(s, arc, pts[:, 1])])
    left = total - s
    cx = np.floor((dense[:, 0] - costmap.origin_x) / res).astype(np.int64)
    cy = np.floor((dense[:, 1] - costmap.origin_y) / res).astype(np.int64)
    ok = (cx >= 0) & (cy >= 0) & (cx < w) & (cy < h)
    cx, cy, left = cx[ok], cy[ok], left[ok]
    mask = np.full((h, w), 255, np.uint8)
    if cx.size == 0:
        inf = np.full((h, w), np.inf, np.float32)
        return inf, inf
    mask[cy, cx] = 0
    dist, labels = chamfer_labels(mask)
    left_cell = np.full((h, w), np.inf)
    np.minimum.at(left_cell, (cy, cx), left)  # a cell's plan length left: its smallest
    lab_left = np.full(int(labels.max()) + 1, np.inf)
    lab_left[labels[cy, cx]] = left_cell[cy, cx]
    return dist * res, lab_left[labels]


def plan_ahead(local, distance):
    """The local plan (M, 2) from `distance` [m] along it on (its last point at least)."""
    if len(local) < 2:
        return local
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(local, axis=0).T))])
    return local[min(int(np.searchsorted(arc, distance)), len(local) - 1):]


def obstacle_costs(ro, k, final, escape):
    """(N,) the obstacle term: the highest costmap cost under the centre over sim_time
    (heading for the goal, up to the closest approach k: cells past the stop do not
    count). In escape mode the cost at the end of sim_time (inscribed at most) plus 100
    per metre of clearance short of 0 there, so that regaining clearance wins."""
    n = ro.n_score
    if escape:
        occ = ro.centre[:, n - 1].astype(np.float64)
        occ[ro.centre[:, n - 1] >= INSCRIBED_INFLATED_OBSTACLE] = INSCRIBED_INFLATED_OBSTACLE
        occ -= 100.0 * np.minimum(ro.clearance[:, n - 1], 0.0)
        return occ
    steps = np.arange(ro.n_steps)[None, :]
    scored = steps[:, :n] <= (k[:, None] if final else n)
    return np.where(ro.inside[:, :n] & scored, ro.centre[:, :n], 0).max(axis=1).astype(np.float64)


def scores(cfg, samples, ro, k, occ, scene, dist_goal):
    """(N,) dwa_local_planner's cost of each sample scored at step k, distances in metres:
    0.5 path_distance_bias (path distance of the scored point + of the forward point)
    + 0.5 goal_distance_bias (goal distance of both) + occdist_scale occ
    + twirling_scale |vth|.

    Goal distance as MapGrid measures it, along the plan (plan length left from the
    nearest plan cell + the distance to it), so turning in place is no progress. The
    forward point (forward_point_distance ahead of the scored pose) is measured the same
    way against the plan from forward_point_distance ahead of the robot on, as the goal
    shifted that far (goal_front_costs) and the nose kept on the path (alignment_costs)
    ask: a nose that points back along the plan is then as far from it as its heading
    error makes it, so a robot facing away from its plan turns toward it the short way.
    Heading for the final goal: path and goal distances within GOAL_DEAD_ZONE x
    xy_goal_tolerance count as 0, the forward-point terms fade out within
    NEAR_GOAL_FACTOR x forward_point_distance of the goal (a trajectory that gets there
    stops), and the earlier arrival wins (ARRIVAL_TIME_WEIGHT)."""
    rows = np.arange(len(samples))
    final, goal = scene.final, scene.goal
    ex, ey, eth = ro.x[rows, k], ro.y[rows, k], ro.th[rows, k]
    fx = ex + cfg.forward_point_distance * np.cos(eth)
    fy = ey + cfg.forward_point_distance * np.sin(eth)
    end, fwd = scene.cells(ex, ey), scene.cells(fx, fy)
    path_end = scene.dist_path[end]
    path_fwd = scene.ahead_path[fwd]
    goal_end = scene.togo[end] + path_end
    if final:
        dead = GOAL_DEAD_ZONE * cfg.xy_goal_tolerance
        path_end = np.maximum(path_end - dead, 0.0)
        goal_end = np.maximum(goal_end - dead, 0.0)
    goal_fwd = scene.ahead_togo[fwd] + path_fwd
    fwd_w = 0.0 if dist_goal <= NEAR_GOAL_FACTOR * cfg.forward_point_distance else 1.0
    if final and cfg.forward_point_distance > 0:
        fwd_w = fwd_w * np.clip(np.hypot(ex - goal[0], ey - goal[1])
                                / (NEAR_GOAL_FACTOR * cfg.forward_point_distance), 0.0, 1.0)
    cost = (0.5 * cfg.path_distance_bias * (path_end + fwd_w * path_fwd)
            + 0.5 * cfg.goal_distance_bias * (goal_end + fwd_w * goal_fwd)
            + cfg.occdist_scale * occ
            + cfg.twirling_scale * np.abs(samples[:, 2]))
    if final:
        cost += ARRIVAL_TIME_WEIGHT * cfg.goal_distance_bias * (k + 1) * ro.dt
    return cost


# -- 6. choice ------------------------------------------------------------------------
def choose(cost, samples, verdict, final):
    """(best, n_valid): the index of the cheapest admissible sample (None when there is
    none) and how many were admissible. Heading for the final goal with every safe sample
    too fast to stop there (it came into view late, odometry jumped), the slowest safe
    ones count as admissible: the robot brakes as hard as the window allows."""
    valid = verdict.valid
    n_valid = int(valid.sum())
    if n_valid == 0 and final and verdict.too_fast.any():
        safe = ~(verdict.collides | verdict.leaves | verdict.oscillates)
        if safe.any():
            speed = np.hypot(samples[:, 0], samples[:, 1])
            valid = safe & (speed <= speed[safe].min() + EPS)
            n_valid = int(valid.sum())
    if n_valid == 0:
        return None, 0
    return int(np.argmin(np.where(valid, cost, np.inf))), n_valid


# -- 7. the reason when nothing is admissible -----------------------------------------
def no_valid_reason(verdict, escape_why, dist_obs, costmap, pose):
    """'no valid trajectory: of N samples n collide, ...': how many samples each
    constraint rejected; escape_why: why escape mode was on (None: it was not); and where
    the nearest blocked cell lies."""
    v = verdict
    counts = [f"{int(v.collides.sum())} collide" + (f" (escape mode, {escape_why}: would lose clearance)"
                                                      if escape_why is not None else ""),
              f"{int(v.leaves.sum())} leave the local costmap", f"{int(v.oscillates.sum())} would "
              "oscillate (reverse a motion just made)", f"{int(v.too_fast.sum())} too fast to stop at the goal"]
    counts = [c for c, m in zip(counts, (v.collides, v.leaves, v.oscillates, v.too_fast)) if m.any()]
    return (f"no valid trajectory: of {len(v.valid)} samples " + ", ".join(counts)
            + _nearest_blocked(dist_obs, costmap, pose))


# -- the planner ----------------------------------------------------------------------
class DWAPlanner(HeldPlan):
    """The DWA local planner (nav_core's BaseLocalPlanner, without ROS).

    config: DWAConfig; footprint: costmap.Footprint; holonomic: sample vy (omni drive),
    default: config.holonomic_robot or max_vel_y > 0 with vy_samples > 1.

    Use: set_plan(plan, goal_yaw) once per global plan, then compute_velocity(pose,
    velocity, costmap) every control period; is_goal_reached() after.
    """

    def __init__(self, config, footprint, holonomic=None):
        self.config = config
        self.footprint = footprint
        if holonomic is None:
            holonomic = config.holonomic_robot or (config.max_vel_y > 0 and config.vy_samples > 1)
        self.holonomic = bool(holonomic)
        self.covers, self.corners = footprint_checks(footprint)
        self.policy = ClearancePolicy(footprint.padding)
        self.oscillation = OscillationFlags(config.oscillation_reset_dist, config.oscillation_reset_angle)
        self.plan = None
        self.goal_yaw = 0.0
        self.xy_latched = False
        self.goal_reached = False
        self._closest = 0
        self._escape_floor = None  # [m] escape mode's clearance floor (None: not escaping)
        # [s] how long a command stays in force before the next one: one control period
        # nominally; move_base sets the measured interval (set_control_latency) when its
        # loop runs late on a loaded machine, so braking plans for the real delay.
        self.latency = config.sim_period

    def __setstate__(self, state):
        """Unpickling (move_base's ~debug_dump_dir, replay_dwa_dump.py), also a planner
        pickled before the ClearancePolicy or with the state since dropped."""
        state = dict(state)
        for gone in ("_debug", "rotating_to_goal"):
            state.pop(gone, None)
        self.__dict__.update(state)
        if "policy" not in state:
            self.policy = ClearancePolicy(self.footprint.padding)

    def set_control_latency(self, seconds):
        """The measured time between control cycles [s] (never less than one period)."""
        if math.isfinite(seconds):
            self.latency = min(MAX_LATENCY, max(self.config.sim_period, float(seconds)))

    def set_plan(self, plan, goal_yaw):
        """A new global plan: (N, 2) points [m] in the costmap frame, goal heading [rad].
        Once the xy goal is latched the robot only turns on the spot: later plans are
        ignored."""
        plan = np.asarray(plan, dtype=np.float64)[:, :2]
        if len(plan) == 0 or not np.isfinite(plan).all() or not math.isfinite(goal_yaw):
            raise ValueError("the plan must be a non-empty list of finite points and goal_yaw finite")
        if self.xy_latched and self.plan is not None:
            return
        new_goal = self.plan is None or np.hypot(*(self.plan[-1] - plan[-1])) > 1e-6 \
            or abs(wrap_angle(goal_yaw - self.goal_yaw)) > 1e-6
        self.plan = plan
        self.goal_yaw = float(goal_yaw)
        self._closest = 0
        if new_goal:
            self.xy_latched = False
            self.goal_reached = False
        self.oscillation.reset()

    def is_goal_reached(self):
        return self.goal_reached

    # -- helpers ------------------------------------------------------------------------
    def _local_plan(self, pose, costmap):
        """The plan from the point nearest the robot until it leaves the costmap."""
        plan = self.plan
        if self.config.prune_plan:
            # Search forward from the last nearest point, only PRUNE_SEARCH_ARC along the
            # plan, so a plan that passes near itself does not make the robot jump ahead.
            seg = plan[self._closest:]
            arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(seg, axis=0).T))])
            lim = int(np.searchsorted(arc, PRUNE_SEARCH_ARC)) + 1
            d = np.hypot(seg[:lim, 0] - pose[0], seg[:lim, 1] - pose[1])
            self._closest += int(np.argmin(d))
            plan = plan[self._closest:]
        _, _, inside = costmap.world_to_map_array(plan)
        out = np.flatnonzero(~inside)
        end = out[0] if len(out) else len(plan)
        return plan[:max(end, 1)] if end > 0 else plan[:0]

    def _footprint_clearance(self, dist_m, costmap, x, y, th):
        """Clearance [m] (negative: collision) of poses (any shape) from lethal/unknown cells.

        See footprint_clearance; the covers are the footprint's axis circles, refined by
        its grid circles where the axis circles come closer than FINE_CHECK_BELOW, and
        its corners checked where the circles come within CORNER_SLACK_CELLS.
        """
        return footprint_clearance(dist_m, costmap, x, y, th, self.covers, self.corners)

    # -- main entry ---------------------------------------------------------------------
    def compute_velocity(self, pose, velocity, costmap):
        """One control cycle.

        pose: (x [m], y [m], yaw [rad]) in the costmap frame; velocity: current body
        velocity (vx, vy, vth) from odometry; costmap: the local Costmap2D (updated).
        Returns a DWAResult.
        """
        cfg = self.config
        if self.plan is None:
            return DWAResult(ok=False, reason="no plan set")
        if not all(math.isfinite(v) for v in tuple(pose) + tuple(velocity)):
            return DWAResult(ok=False, reason=f"pose {pose} or velocity {velocity} not finite")
        goal = self.plan[-1]
        dist_goal = math.hypot(goal[0] - pose[0], goal[1] - pose[1])
        if self.goal_reached:
            return DWAResult(goal_reached=True, mode="goal")
        if self.xy_latched and dist_goal > UNLATCH_FACTOR * cfg.xy_goal_tolerance:
            # Latched while passing the goal at speed, then braked beyond it: drive back
            # rather than turn on the spot and report a goal it is not at.
            self.xy_latched = False
        if dist_goal <= cfg.xy_goal_tolerance or (cfg.latch_xy_goal_tolerance and self.xy_latched):
            if cfg.latch_xy_goal_tolerance:
                self.xy_latched = True
            return self._stop_and_rotate(pose, velocity, costmap)
        res = self._dwa_step(pose, velocity, costmap, force_escape=False)
        if not res.ok and res.mode == "dwa" and res.n_samples > 0:
            # Pressed against the clearance limit (c0 just >= 0) every motion may dip below
            # it: fall back to escape mode (no clearance loss, slow reversing allowed).
            res = self._dwa_step(pose, velocity, costmap, force_escape=True)
        return res

    compute_velocity_commands = compute_velocity   # nav_core's name (BaseLocalPlanner)

    def _scene(self, local, costmap):
        """The Scene of a cycle over the local plan local (M, 2)."""
        dist_obs = obstacle_distance(costmap)
        if dist_obs is None:
            dist_obs = np.full(costmap.data.shape, NO_OBSTACLE_DIST, dtype=np.float32)
        dist_path, togo = path_distance_maps(local, costmap)
        ahead_path, ahead_togo = path_distance_maps(plan_ahead(local, self.config.forward_point_distance), costmap)
        if self.config.prune_plan:
            final = len(local) == len(self.plan) - self._closest
        else:
            final = len(local) == len(self.plan)
        return Scene(costmap, dist_obs, dist_path, togo, ahead_path, ahead_togo, local, self.plan, final)

    def _dwa_step(self, pose, velocity, costmap, force_escape):
        """The pipeline, steps 1-7; escape mode when forced, or when the robot starts
        inside its padding (clearance < 0) or on an inscribed or unknown cell."""
        cfg = self.config
        local = self._local_plan(pose, costmap)
        if len(local) == 0:
            return DWAResult(ok=False, reason="the global plan does not reach into the local costmap")
        scene = self._scene(local, costmap)

        def clearance(x, y, th):
            return self._footprint_clearance(scene.dist_obs, costmap, x, y, th)
        c0 = float(clearance(np.array(pose[0]), np.array(pose[1]), np.array(pose[2])))
        cc = costmap.cost_at(pose[0], pose[1])
        escape = force_escape or c0 < 0 or cc is None or cc >= INSCRIBED_INFLATED_OBSTACLE
        floor = self.policy.escape_floor(c0, self._escape_floor) if escape else None
        self._escape_floor = floor
        mode = "escape" if escape else "dwa"

        scfg = sampling_config(cfg, escape)                                   # 1, 2
        samples = sample_velocities(scfg, dynamic_window(scfg, velocity), self.holonomic)
        if len(samples) == 0:
            return DWAResult(ok=False, reason="no velocity sample in the dynamic window")
        n_steps = simulation_steps(cfg, samples, cfg.horizon)
        dist_goal = math.hypot(scene.goal[0] - pose[0], scene.goal[1] - pose[1])
        speed = math.hypot(velocity[0], velocity[1])
        oscillates = self.oscillation.forbidden(samples)
        # Steps 3-5 block by block of samples: every step is per sample, and a block's
        # (rows, n_steps) arrays stay below glibc's mmap threshold (summit_nav_common.malloc),
        # so they are reused from the heap, not mapped and zeroed anew every cycle.
        block = max(1, BLOCK_BYTES // (8 * n_steps))
        costs, verdicts = [], []
        for lo in range(0, len(samples), block):
            rows = slice(lo, lo + block)
            ro = rollouts(cfg, pose, samples[rows], costmap, clearance, self.latency, n_steps)  # 3
            k, too_fast = goal_approach(cfg, samples[rows], ro, scene, dist_goal, speed, self.latency)   # 4
            n_check, n_brake = check_horizon(cfg, samples[rows], ro, k, scene.final, self.latency)
            if escape:
                verdicts.append(escape_admissibility(self.policy, floor, c0, speed if c0 < 0.0 else 0.0,
                                                     samples[rows], ro, k, n_check, n_brake, oscillates[rows],
                                                     too_fast, scene, pose))
            else:
                verdicts.append(ordinary_admissibility(self.policy, ro, k, n_check, oscillates[rows], too_fast,
                                                       costmap))
            costs.append(scores(cfg, samples[rows], ro, k, obstacle_costs(ro, k, scene.final, escape), scene,
                                dist_goal))                                   # 5
        cost, verdict = np.concatenate(costs), Verdict.join(verdicts)
        if escape:
            verdict = boxed_in(verdict)
        best, n_valid = choose(cost, samples, verdict, scene.final)           # 6
        if best is None:                                                      # 7
            why = None
            if escape:
                why = ("forced, no ordinary trajectory" if c0 >= 0 and cc is not None
                       and cc < INSCRIBED_INFLATED_OBSTACLE else f"clearance {c0:+.3f} m")
            return DWAResult(ok=False, reason=no_valid_reason(verdict, why, scene.dist_obs, costmap, pose),
                             n_samples=len(samples), mode=mode)
        cmd = tuple(float(v) for v in samples[best])
        self.oscillation.update(tuple(pose), cmd, cfg.min_vel_trans)
        n = ro.n_score
        x, y, th = simulate(pose, samples[best:best + 1], ro.dt, n_steps)   # its rows, as in its block
        traj = np.column_stack([x[0, :n], y[0, :n], th[0, :n]])
        return DWAResult(cmd=cmd, trajectory=traj, n_valid=n_valid, n_samples=len(samples),
                         cost=float(cost[best]), mode=mode)

    # -- goal: stop, rotate, done --------------------------------------------------------
    def _stopped(self, velocity):
        cfg = self.config
        return (abs(velocity[0]) <= cfg.trans_stopped_vel and abs(velocity[1]) <= cfg.trans_stopped_vel
                and abs(velocity[2]) <= cfg.theta_stopped_vel)

    def _rotation_is_free(self, pose, vth, costmap):
        """Footprint check of an in-place rotation at vth [rad/s] over sim_time."""
        cfg = self.config
        dist = obstacle_distance(costmap)
        if dist is None:
            return True
        n = max(2, int(math.ceil(abs(vth) * cfg.sim_time / cfg.angular_sim_granularity)))
        ths = pose[2] + vth * cfg.sim_time * np.arange(1, n + 1) / n
        clear = self._footprint_clearance(dist, costmap, np.full(n, pose[0]), np.full(n, pose[1]), ths)
        c0 = self._footprint_clearance(dist, costmap, np.array(pose[0]), np.array(pose[1]), np.array(pose[2]))
        return bool(clear.min() >= self.policy.rotation(float(c0)))

    def _stop_and_rotate(self, pose, velocity, costmap):
        cfg = self.config
        err = wrap_angle(self.goal_yaw - pose[2])
        dt = self.latency   # each command stays in force this long (a late loop: longer)
        if abs(err) <= cfg.yaw_goal_tolerance:
            # base_local_planner: the goal counts only once the robot has stopped there;
            # declaring it while still turning lets the heading coast past the tolerance.
            if self._stopped(velocity):
                self.goal_reached = True
                return DWAResult(goal_reached=True, mode="goal")
            return DWAResult(cmd=(braked(velocity[0], cfg.acc_lim_x, dt), braked(velocity[1], cfg.acc_lim_y, dt),
                                  braked(velocity[2], cfg.acc_lim_theta, dt)), mode="stop")
        # Brake the translation as hard as allowed (stopWithAccLimits) and, at the same
        # time, start the turn: vx and vth have separate acceleration limits, so turning
        # while braking over the last centimetres costs no position and saves the
        # stop-then-turn pause of LatchedStopRotateController.
        vx, vy = braked(velocity[0], cfg.acc_lim_x, dt), braked(velocity[1], cfg.acc_lim_y, dt)
        vth = rotation_speed(err, velocity[2], cfg.acc_lim_theta, cfg.max_vel_theta,
                             cfg.min_vel_theta, cfg.yaw_goal_tolerance, dt)
        moving = abs(vx) > EPS or abs(vy) > EPS
        if not self._rotation_is_free(pose, vth, costmap):
            if moving:
                return DWAResult(cmd=(vx, vy, braked(velocity[2], cfg.acc_lim_theta, dt)), mode="stop")
            return DWAResult(ok=False, reason="cannot rotate to the goal heading: the footprint "
                             "would hit an obstacle", mode="rotate")
        if moving:
            return DWAResult(cmd=(vx, vy, vth), mode="stop")
        return DWAResult(cmd=(0.0, 0.0, vth), mode="rotate")
