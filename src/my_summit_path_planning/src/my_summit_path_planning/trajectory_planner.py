"""base_local_planner's TrajectoryPlannerROS: Trajectory Rollout and its DWA mode.

Reference: Gerkey & Konolige 2008, "Planning and Control in Unstructured Terrain"
(Trajectory Rollout); Fox, Burgard & Thrun 1997 (the Dynamic Window Approach); ROS 1
``base_local_planner`` (trajectory_planner.cpp, trajectory_planner_ros.cpp, map_grid.cpp,
costmap_model.cpp, goal_functions.cpp) and wiki.ros.org/base_local_planner for the
parameters. move_base's default local planner; the course's navigation_stage lesson
configures it. In the order one control cycle runs:

1. ``window_plan``: the plan points within half the local costmap's size of the robot
   (transformGlobalPlan), the points behind the first one within 1 m of the robot
   dropped for good (prunePlan, with prune_plan).
2. ``map_grids``: two distance grids over the local costmap, in cells, by a 4-connected
   breadth-first wavefront (MapGrid): path distance from every plan cell, goal distance
   from the local goal (where the plan leaves the costmap, or its end). A lethal,
   inscribed or unknown cell stops the wave and holds obstacle_cost (the number of
   cells); a cell the wave never reaches holds one more. Cells under the robot's
   current footprint never stop the path wave (within_robot, set in the path grid
   only): they still stop the goal wave, so no trajectory point lies on a blocked cell.
3. ``velocity samples``: vx over [min_vel_x, max_vel_x] and vtheta over
   [min_vel_theta, max_vel_theta] clipped to what acc_lim_* reach within sim_time
   (Trajectory Rollout, dwa: false) or within one sim_period = 1/controller_frequency
   (dwa: true); max_vel_x also capped to (distance to the plan's end) / sim_time.
   Samples come in groups: forward (vx_samples x [0, vtheta_samples - 1 rates], plus
   (0.1, +-0.1, 0) strafing diagonals for a holonomic robot), rotating in place
   (vtheta_samples rates, none slower than min_in_place_vel_theta), then only if none
   of those is legal sideways (y_vels, holonomic) and last backing up at escape_vel.
4. ``rollout``: every sample simulated for sim_time from the current pose and velocity,
   the velocity ramping to the sample within acc_lim_* (base_local_planner's
   computeNewVelocity), in steps of sim_granularity [m] / angular_sim_granularity
   (vtheta / angular_sim_granularity steps, not x sim_time, as the real planner). At each
   point, the current pose first: the centre must lie on the costmap, the footprint
   outline (its edges rasterized with Bresenham's line, CostmapModel) must not touch a
   lethal or unknown cell (cost -1), and the path and goal distances must be below
   obstacle_cost (cost -2: no clear way to the plan). Cost of a legal trajectory:
   path_distance_bias * path_dist + goal_distance_bias * goal_dist
   + occdist_scale * max(footprint outline cost, centre cell cost) over its points,
   path_dist and goal_dist being those of its last point [cells; x resolution with
   meter_scoring]. heading_scoring scores path and goal distance at the point
   heading_scoring_timestep into the trajectory, plus 0.3 x the angle to the farthest
   plan point in line of sight; simple_attractor scores the squared distance to the
   plan's end instead.
5. ``choice``: the cheapest legal forward sample (earliest on ties); a rotation in place
   replaces it when it costs no more (or the best strafes), preferring the rotation
   whose heading_lookahead point is nearest the goal and not the direction the stuck
   flags forbid; then strafes; then, with nothing legal, back up at escape_vel and enter
   escape mode (no forward samples until the robot has moved escape_reset_dist or
   turned escape_reset_theta). The stuck flags (set when the robot has turned, or
   strafed, the same way on two cycles without moving oscillation_reset_dist) forbid
   the other way, so it does not rock left-right on the spot.

Goal (TrajectoryPlannerROS::computeVelocityCommands): within xy_goal_tolerance (latched
with latch_xy_goal_tolerance) the robot brakes at acc_lim_* (stopWithAccLimits) until
stopped (|v| <= 0.01), then rotates in place toward the goal heading at
min(max_vel_theta, max(min_in_place_vel_theta, |error|)) within the acceleration
window and sqrt(2 acc_lim_theta |error|) (rotateToGoal), every command checked as a
trajectory; the goal is reached once the heading is within yaw_goal_tolerance.

Backing up in escape mode is commanded even when its trajectory meets an obstacle, as
in the real planner: the outline check fails for every sample, the backing one too, as
soon as the robot's current outline touches a lethal cell. It is refused where there is
no way to the plan (cost -2), as in the real planner, and where it would bring the
footprint deeper onto a lethal cell than contact or than the robot already is in that
lane (backs_onto_obstacle: a wall behind, or one closing in on a rear corner; a side wall
it slides along is let through), where the real planner backs into it.

Where else this differs from the real node: the goal is the plan's last point (the real node
takes the last point of the windowed plan: the same whenever the goal is in the local
costmap); at the goal only the distance grids are rebuilt (the real node runs a whole
sampling cycle there too, for its side effects); a robot with no plan point within 1 m
gets no command but keeps its plan (the real prunePlan erases the windowed points).
Defaults are the wiki's (the real node's dynamic_reconfigure defaults differ, e.g.
sim_time 1.7, vx_samples 20); acc_lim_th and max_rotational_vel are mapped to
acc_lim_theta and max_vel_theta / min_vel_theta with nav_core's deprecation warning
(Noetic's node reads the first not at all and lets dynamic_reconfigure override the
second).

Speed: the trajectories of all samples are simulated at once with numpy (``rollout``:
velocity ramps and poses as cumulative sums, the footprint's vertex cells of every
point); the checks then walk each trajectory point by point in a compiled kernel
(``first_failure``: the outline's Bresenham cells, stopping at the first point that
fails, as generateTrajectory does), and the distance grids are a compiled breadth-first
queue (``wavefront``). Both are C (summit_nav_common/csrc/trajectory.c, built by catkin,
called through ctypes: no numba and its LLVM in move_base); their Python twins
(``_first_failure``, ``_wavefront``) are the C's bit-for-bit oracle.
``generate_trajectory_reference``,
``map_grid_reference``, ``footprint_cells_reference`` and ``densify_reference`` are the
literal per-trajectory loops and queue, kept as the test oracle (TrajectoryPlanner(...,
reference=True) runs on the first two).
"""
import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from .cost_values import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
from .footprint_cost import (COLLIDES, OFF_MAP, _outline_cost, _vertex_cells, bresenham, check_vertex_cells,
                             footprint_cost_reference, world_to_cells)
from .goal_approach import braked, rotate_to_goal_speed
from .local_plan import DWAResult, HeldPlan
from .param_reader import WARNING, Note, ParamError, Schema
from summit_nav_common.geometry import inverse, transform_points, wrap_angle
from summit_nav_common.native import library

PRUNE_DIST = 1.0            # [m] prunePlan drops plan points until one this near the robot
STOPPED_VEL = 1e-2          # [m/s, rad/s] TrajectoryPlannerROS: below this the robot counts as stopped
HEADING_WEIGHT = 0.3        # heading_scoring: weight of the heading difference [1/rad]
HOLONOMIC_DIAGONAL = 0.1    # [m/s] vx and |vy| of the two strafing-forward samples
DEFAULT_SIM_PERIOD = 0.05   # [s] when controller_frequency is not positive (20 Hz)
NO_WAY = -2.0               # trajectory cost: a point with no clear path to the plan or goal


@dataclass
class TrajectoryPlannerConfig:
    """TrajectoryPlannerROS's parameters (the real names, defaults and units)."""

    acc_lim_x: float = 2.5                 # [m/s^2]
    acc_lim_y: float = 2.5                 # [m/s^2]
    acc_lim_theta: float = 3.2             # [rad/s^2]
    max_vel_x: float = 0.5                 # [m/s]
    min_vel_x: float = 0.1                 # [m/s] enough to overcome the base's friction
    max_vel_theta: float = 1.0             # [rad/s]
    min_vel_theta: float = -1.0            # [rad/s] (negative: turning right)
    min_in_place_vel_theta: float = 0.4    # [rad/s] slowest turn in place
    escape_vel: float = -0.1               # [m/s] backing-up speed in escape mode (negative)
    holonomic_robot: bool = True           # sample strafing (vy) trajectories
    y_vels: tuple = (-0.3, -0.1, 0.1, 0.3)  # [m/s] strafing speeds tried when nothing else is legal
    sim_time: float = 1.0                  # [s] forward-simulation horizon
    sim_granularity: float = 0.025         # [m] step between simulated points
    angular_sim_granularity: float = None  # [rad] step for rotations; None: sim_granularity
    vx_samples: int = 3
    vtheta_samples: int = 20
    controller_frequency: float = 20.0     # [Hz] sim_period = 1 / controller_frequency (dwa)
    path_distance_bias: float = 0.6        # weight of the distance to the path [1/cell or 1/m]
    goal_distance_bias: float = 0.8        # weight of the distance to the local goal
    occdist_scale: float = 0.01            # weight of the highest cell cost under the footprint
    meter_scoring: bool = False            # distances in metres (else cells)
    heading_lookahead: float = 0.325       # [m] look-ahead of the in-place rotations' scoring
    heading_scoring: bool = False          # score the heading instead of the end point's distance
    heading_scoring_timestep: float = 0.8  # [s] where along the trajectory heading is scored
    oscillation_reset_dist: float = 0.05   # [m] travel that clears the stuck flags
    escape_reset_dist: float = 0.10        # [m] travel that ends escape mode
    escape_reset_theta: float = math.pi / 4  # [rad] turn that ends escape mode
    prune_plan: bool = True                # drop plan points as the robot passes them
    xy_goal_tolerance: float = 0.1         # [m]
    yaw_goal_tolerance: float = 0.05       # [rad]
    latch_xy_goal_tolerance: bool = False  # once within xy tolerance, only rotate
    dwa: bool = True                       # sample the window of one sim_period (else sim_time); the
                                           # real default (trajectory_planner_ros.cpp and the wiki: true)
    simple_attractor: bool = False         # score the squared distance to the plan's end only
    stop_time_buffer: float = 0.2          # [s] read by the real node, unused by its planner

    @property
    def sim_period(self):
        """[s] one control period (a non-positive controller_frequency counts as 20 Hz)."""
        return 1.0 / self.controller_frequency if self.controller_frequency > 0 else DEFAULT_SIM_PERIOD

    @property
    def angular_granularity(self):
        """[rad] angular_sim_granularity, defaulting to sim_granularity."""
        return self.sim_granularity if self.angular_sim_granularity is None else self.angular_sim_granularity


# Deprecated name -> current name, read when the current one is unset with nav_core's
# warning (loadParameterWithDeprecation); backup_vel with the real node's own text.
DEPRECATED = {
    "pdist_scale": "path_distance_bias",
    "gdist_scale": "goal_distance_bias",
    "min_in_place_rotational_vel": "min_in_place_vel_theta",
    "max_rotational_vel": "max_vel_theta",
    "acc_lim_th": "acc_lim_theta",
    "backup_vel": "escape_vel",
}
BACKUP_VEL_WARNING = ("The backup_vel parameter has been deprecated in favor of the escape_vel parameter. "
                      "To switch, just change the parameter name in your configuration files.")
# Names the real node reads only to complain about (the wiki used to spell them so).
MISSPELLED = {"acc_limit_x": "acc_lim_x", "acc_limit_y": "acc_lim_y", "acc_limit_th": "acc_lim_th"}
# Read by the real node but without effect here (logged as ignored by the node).
ACCEPTED_UNUSED = ("world_model", "point_grid", "restore_defaults", "publish_cost_grid_pc")
METER_SCORING_UNSET = ("Trajectory Rollout planner initialized with param meter_scoring not set. Set it to "
                       "true to make your settings robust against changes of costmap resolution.")
METER_SCORING_FALSE = ("Trajectory Rollout planner initialized with param meter_scoring set to false. Set it "
                       "to true to make your settings robust against changes of costmap resolution.")


def _misspelled_warning(old):
    return (f"You are using {old} where you should be using {MISSPELLED[old]}. Please change your "
            "configuration files appropriately. The documentation used to be wrong on this, "
            "sorry for any confusion.")


def _no_samples_warning(dim, name):
    return (f"You've specified that you don't want any samples in the {dim} dimension. We'll at "
            f"least assume that you want to sample one value... so we're going to set {name} to 1 instead")


def _schema():
    fields = {new: dict(old=((old, BACKUP_VEL_WARNING),) if old == "backup_vel" else (old,))
              for old, new in DEPRECATED.items()}
    fields["acc_lim_theta"]["renamed"] = (("acc_limit_th", _misspelled_warning("acc_limit_th")),)
    for name in ("acc_lim_x", "acc_lim_y"):
        fields[name] = dict(renamed=((f"acc_limit_{name[-1]}", _misspelled_warning(f"acc_limit_{name[-1]}")),))
    for name in ("acc_lim_x", "acc_lim_y", "acc_lim_theta", "xy_goal_tolerance", "yaw_goal_tolerance"):
        fields[name] = dict(fields.get(name, {}), lo=0)
    for name in ("sim_time", "sim_granularity", "angular_sim_granularity"):
        fields[name] = dict(lo=0, lo_open=True)
    for name, dim in (("vx_samples", "x"), ("vtheta_samples", "theta")):
        fields[name] = dict(lo=1, clamp=True, note=_no_samples_warning(dim, name))
    return Schema.of(TrajectoryPlannerConfig, accepted=ACCEPTED_UNUSED, **fields)


SCHEMA = _schema()
KNOWN_PARAMS = frozenset(SCHEMA.known)


def trajectory_planner_config(params, where="TrajectoryPlannerROS", controller_frequency=None, note_where=None):
    """(TrajectoryPlannerConfig, notes) from a TrajectoryPlannerROS dict (SCHEMA).

    controller_frequency [Hz]: move_base's, used when the namespace has none (the real
    node searches upward for it). notes (param_reader Notes): the real node's texts for
    deprecated and misspelled names and doubtful values, and the names this planner does
    not know (prefixed with note_where, default where), for the caller to log once.
    ParamError on a value of the wrong type or range.
    """
    r = SCHEMA.read(params, where, note_where)
    params, values, notes = params or {}, r.values, r.notes
    if "max_rotational_vel" in params and "max_vel_theta" not in params and "min_vel_theta" not in params:
        values["min_vel_theta"] = -values["max_vel_theta"]
    if params.get("world_model", "costmap") != "costmap":
        raise ParamError(f"{where}/world_model: only 'costmap' is supported, got {params['world_model']!r}")
    if "controller_frequency" not in r.given and controller_frequency is not None:
        values["controller_frequency"] = SCHEMA.read({"controller_frequency": controller_frequency},
                                                     where)["controller_frequency"]
    cfg = TrajectoryPlannerConfig(**values)
    if "meter_scoring" not in params:
        notes.append(Note(WARNING, "meter_scoring", METER_SCORING_UNSET))
    elif not cfg.meter_scoring:
        notes.append(Note(WARNING, "meter_scoring", METER_SCORING_FALSE))
    if cfg.controller_frequency <= 0:
        notes.append(Note(WARNING, "controller_frequency", "A controller_frequency less than 0 has been set. "
                          "Ignoring the parameter, assuming a rate of 20Hz"))
    if cfg.escape_vel >= 0.0:
        notes.append(Note(WARNING, "escape_vel", "You've specified a positive escape velocity. This is probably "
                          "not what you want and will cause the robot to move forward instead of backward. You "
                          "should probably change your escape_vel parameter to be negative"))
    return cfg, notes


def _outline_cells(costmap, polygon, pose):
    """(xs, ys): the cells of the footprint's closed outline at pose (Bresenham, ends included)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    px = pose[0] + polygon[:, 0] * c - polygon[:, 1] * s
    py = pose[1] + polygon[:, 0] * s + polygon[:, 1] * c
    vx, vy, _ = world_to_cells(costmap, px, py)
    xs, ys, valid = bresenham(vx, vy, np.roll(vx, -1), np.roll(vy, -1))
    return xs[valid], ys[valid]


def polygon_signed_distance(polygon, px, py):
    """Signed distance [m] of points (px, py) (same-shape arrays) from the closed polygon's
    outline: positive outside, negative inside (even-odd rule)."""
    ax, ay = polygon[:, 0], polygon[:, 1]
    bx, by = np.roll(ax, -1), np.roll(ay, -1)
    p_x, p_y = np.asarray(px, float)[..., None], np.asarray(py, float)[..., None]
    ex, ey = bx - ax, by - ay
    t = np.clip(((p_x - ax) * ex + (p_y - ay) * ey) / np.maximum(ex * ex + ey * ey, 1e-300), 0.0, 1.0)
    dist = np.hypot(p_x - ax - t * ex, p_y - ay - t * ey).min(axis=-1)
    crosses = ((ay > p_y) != (by > p_y)) & (p_x < ax + (p_y - ay) * ex / np.where(ey == 0.0, 1.0, ey))
    return np.where(crosses.sum(axis=-1) % 2 == 1, -dist, dist)


BACKUP_CONTACT = 0.5                    # [cells] a cell centre this near the (padded) outline: its square reaches it
BACKUP_SLACK = 0.25                     # [cells] deeper than the deepest contact now by more: refused


def backs_onto_obstacle(costmap, polygon, pose, distance):
    """Whether backing up distance [m] from pose drives the footprint onto a lethal cell.

    The footprint's clearance to a lethal cell is the signed distance of the cell's centre
    from its outline (negative inside). Cells the back-up moves away from (the wall ahead
    that made every sample fail) do not count. Each of the others may come no more than a
    quarter cell deeper than the deeper of contact (the cell's square reaching the outline)
    and the deepest cell of its lane (within a cell sideways, in the robot's frame) now: a
    wall along the side the robot already touches may stay touched as the robot slides
    along it, a wall behind it or one that closes in on a rear corner may not."""
    res = costmap.resolution
    reach = float(np.hypot(polygon[:, 0], polygon[:, 1]).max()) + distance + 2.0 * res
    rows, cols = np.nonzero(costmap.data == LETHAL_OBSTACLE)
    if len(rows) == 0:
        return False
    centres = np.column_stack(costmap.map_to_world(cols, rows))
    rx, ry = transform_points(centres, inverse(pose)).T          # in the robot's frame
    near = np.hypot(rx, ry) <= reach
    rx, ry = rx[near], ry[near]
    if len(rx) == 0:
        return False
    back = np.linspace(0.0, distance, max(2, int(math.ceil(distance / (0.5 * res))) + 1))
    d = polygon_signed_distance(polygon, rx[None, :] + back[:, None], ry[None, :])  # (steps, cells)
    now, closest = d[0], d.min(axis=0)
    eps = 1e-3 * res
    keep = ~((closest >= now - eps) & (d[-1] > now + eps))     # not moving away
    now, closest, ry = now[keep], closest[keep], ry[keep]
    if len(now) == 0:
        return False
    # how deep each may go: contact, or the deepest cell in its lane (within a cell
    # sideways) is now, whichever is deeper; a wall the side is pressed into does not
    # license a wall behind
    lane = np.abs(ry[:, None] - ry[None, :]) <= res
    ref = np.minimum(BACKUP_CONTACT * res, np.where(lane, now[None, :], np.inf).min(axis=1))
    return bool((closest < ref - BACKUP_SLACK * res).any())


def footprint_cells(costmap, polygon, pose):
    """(H, W) bool: the cells of the footprint at pose, its outline and inside (FootprintHelper)."""
    h, w = costmap.data.shape
    mask = np.zeros((h, w), dtype=bool)
    xs, ys = _outline_cells(costmap, polygon, pose)
    # Fill each column between its lowest and highest outline cell (a convex footprint).
    x0 = int(xs.min())
    cols = xs - x0
    lo = np.full(int(cols.max()) + 1, np.iinfo(np.int64).max)
    hi = np.full(len(lo), np.iinfo(np.int64).min)
    np.minimum.at(lo, cols, ys)
    np.maximum.at(hi, cols, ys)
    rows = np.arange(h)[:, None]
    cx = np.arange(x0, x0 + len(lo))
    on = (cx >= 0) & (cx < w)
    mask[:, cx[on]] = (rows >= lo[on]) & (rows <= hi[on])
    return mask


def footprint_cells_reference(costmap, polygon, pose):
    """footprint_cells column by column (test oracle)."""
    h, w = costmap.data.shape
    mask = np.zeros((h, w), dtype=bool)
    xs, ys = _outline_cells(costmap, polygon, pose)
    for cx in np.unique(xs):
        if 0 <= cx < w:
            col = ys[xs == cx]
            lo, hi = max(0, col.min()), min(h, col.max() + 1)
            if hi > lo:   # a column wholly below the costmap has no cell on it
                mask[lo:hi, cx] = True
    return mask


# -- 2. distance grids --------------------------------------------------------------------
def densify(plan, resolution):
    """MapGrid::adjustPlanResolution: points added so that neighbours are at most resolution [m] apart."""
    plan = np.asarray(plan, dtype=np.float64)
    if len(plan) < 2:
        return plan.copy()
    a, step = plan[:-1], plan[1:] - plan[:-1]
    steps = np.array([int(math.ceil(d / resolution)) if d > resolution else 1
                      for d in map(math.hypot, step[:, 0].tolist(), step[:, 1].tolist())])
    # Segment k contributes a + j (b - a) / steps for j = 0 .. steps - 1 (j = 0: a itself)
    seg = np.repeat(np.arange(len(step)), steps)
    j = (np.arange(len(seg)) - np.repeat(np.cumsum(steps) - steps, steps))[:, None]
    pts = a[seg] + j * step[seg] / steps[seg][:, None]
    pts[j[:, 0] == 0] = a[seg[j[:, 0] == 0]]
    return np.vstack([pts, plan[-1:]])


def densify_reference(plan, resolution):
    """densify segment by segment (test oracle)."""
    plan = np.asarray(plan, dtype=np.float64)
    out = [plan[:1]]
    for a, b in zip(plan[:-1], plan[1:]):
        d = math.hypot(b[0] - a[0], b[1] - a[1])
        if d > resolution:
            steps = int(math.ceil(d / resolution))
            j = np.arange(1, steps)[:, None]
            out.append(a + j * (b - a) / steps)
        out.append(b[None])
    return np.vstack(out)


def plan_cells(costmap, plan):
    """The plan's cells from its first on the costmap and known, until it leaves (setTargetCells):
    (mx, my) int arrays, in plan order (may repeat), over the densified plan."""
    dense = densify(plan, costmap.resolution)
    mx, my, inside = world_to_cells(costmap, dense[:, 0], dense[:, 1])
    ok = inside.copy()
    ok[inside] = costmap.data[my[inside], mx[inside]] != NO_INFORMATION
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return mx[:0], my[:0]
    start = idx[0]
    stop = np.flatnonzero(~ok[start:])
    end = start + (stop[0] if stop.size else len(ok) - start)
    return mx[start:end], my[start:end]


def blocked_cells(costmap, within_robot):
    """(H, W) bool: cells the wavefront cannot cross (lethal, inscribed, unknown), not under the robot."""
    d = costmap.data
    return ((d == LETHAL_OBSTACLE) | (d == INSCRIBED_INFLATED_OBSTACLE) | (d == NO_INFORMATION)) & ~within_robot


def _wavefront(blocked, tx, ty, obstacle):
    """The breadth-first wave of map_grid over blocked (H, W) bool from the target cells
    (tx, ty), with a flat array as its queue (each cell enters it at most once)."""
    h, w = blocked.shape
    dist = np.full((h, w), obstacle + 1.0)
    marked = np.zeros((h, w), dtype=np.bool_)
    queue = np.empty(h * w + tx.shape[0], dtype=np.int64)
    head, tail = 0, 0
    for k in range(tx.shape[0]):
        dist[ty[k], tx[k]] = 0.0
        marked[ty[k], tx[k]] = True
        queue[tail] = ty[k] * w + tx[k]
        tail += 1
    while head < tail:
        cx, cy = queue[head] % w, queue[head] // w
        head += 1
        d = dist[cy, cx] + 1.0
        for j in range(4):
            nx = cx - 1 if j == 0 else cx + 1 if j == 1 else cx
            ny = cy - 1 if j == 2 else cy + 1 if j == 3 else cy
            if nx < 0 or ny < 0 or nx >= w or ny >= h or marked[ny, nx]:
                continue
            marked[ny, nx] = True
            if blocked[ny, nx]:
                dist[ny, nx] = obstacle
                continue
            dist[ny, nx] = d
            queue[tail] = ny * w + nx
            tail += 1
    return dist


def wavefront(blocked, tx, ty, obstacle):
    """_wavefront in C: (H, W) float64 distances [cells] over blocked (H, W) bool from the
    target cells (tx, ty) (on the grid)."""
    blocked = np.ascontiguousarray(blocked, dtype=bool)
    h, w = blocked.shape
    tx, ty = np.ascontiguousarray(tx, dtype=np.int64).ravel(), np.ascontiguousarray(ty, dtype=np.int64).ravel()
    if tx.shape != ty.shape:
        raise ValueError(f"wavefront: {tx.size} x but {ty.size} y target cells")
    if tx.size and (tx.min() < 0 or ty.min() < 0 or tx.max() >= w or ty.max() >= h):
        raise ValueError(f"wavefront: a target cell off the {w} x {h} grid")
    dist = np.empty((h, w))
    if library().snc_tp_wavefront(blocked.view(np.uint8), h, w, tx, ty, tx.size, float(obstacle), dist):
        raise MemoryError("wavefront: out of memory")
    return dist


def map_grid(costmap, targets, within_robot):
    """MapGrid::computeTargetDistance: (H, W) float distances [cells].

    targets: (mx, my) arrays of cells at distance 0; a 4-connected breadth-first wave
    spreads from them over free cells; a blocked cell it touches gets obstacle_cost
    (H x W) and stops it; cells never touched get obstacle_cost + 1.
    """
    mx, my = (np.asarray(v, dtype=np.int64).ravel() for v in targets)
    return wavefront(blocked_cells(costmap, within_robot), mx, my, float(costmap.data.size))


def map_grid_reference(costmap, targets, within_robot):
    """The wavefront with a queue, cell by cell, as MapGrid does it (test oracle of map_grid)."""
    h, w = costmap.data.shape
    obstacle = float(h * w)
    blocked = blocked_cells(costmap, within_robot)
    dist = np.full((h, w), obstacle + 1.0)
    marked = np.zeros((h, w), dtype=bool)
    queue = deque()
    for cx, cy in zip(*targets):
        dist[cy, cx] = 0.0
        marked[cy, cx] = True
        queue.append((int(cx), int(cy)))
    while queue:
        cx, cy = queue.popleft()
        for nx, ny in ((cx - 1, cy), (cx + 1, cy), (cx, cy - 1), (cx, cy + 1)):
            if not (0 <= nx < w and 0 <= ny < h) or marked[ny, nx]:
                continue
            marked[ny, nx] = True
            if blocked[ny, nx]:
                dist[ny, nx] = obstacle
                continue
            dist[ny, nx] = min(dist[ny, nx], dist[cy, cx] + 1.0)
            queue.append((nx, ny))
    return dist


@dataclass
class Grids:
    """One cycle's scoring inputs: path and goal distance grids [cells], the plan they
    came from (the windowed plan, costmap frame [m]) and its local goal cell."""

    path: np.ndarray
    goal: np.ndarray
    plan: np.ndarray
    obstacle_cost: float


def map_grids(costmap, plan, polygon, pose, grid_fn=map_grid):
    """Path and goal distance grids for the windowed plan (N, 2) [m] and the robot at pose.

    Only the path grid's wave crosses the cells under the robot's footprint (findBestPath
    marks within_robot in path_map_ alone): the goal grid's stops at every blocked cell,
    so no trajectory point may lie on an inscribed, lethal or unknown cell."""
    within = footprint_cells(costmap, polygon, pose)
    mx, my = plan_cells(costmap, plan)
    path = grid_fn(costmap, (mx, my), within)
    goal_cell = (mx[-1:], my[-1:])
    goal = grid_fn(costmap, goal_cell, np.zeros_like(within))
    return Grids(path=path, goal=goal, plan=np.asarray(plan, dtype=np.float64),
                 obstacle_cost=float(costmap.data.size))


# -- 4. rollouts ----------------------------------------------------------------------------
def step_counts(cfg, samples):
    """(N,) simulation steps of each sample (generateTrajectory's num_steps, at least 1)."""
    if cfg.heading_scoring:
        n = np.full(len(samples), int(cfg.sim_time / cfg.sim_granularity + 0.5))
    else:
        vmag = np.hypot(samples[:, 0], samples[:, 1])
        n = np.floor(np.maximum(vmag * cfg.sim_time / cfg.sim_granularity,
                                np.abs(samples[:, 2]) / cfg.angular_granularity) + 0.5).astype(np.int64)
    return np.maximum(n, 1)


def _ramp(v0, vg, a_dt, n_steps):
    """(N, n_steps) velocities after 1..n_steps steps ramping from v0 toward vg (N, 1) by
    a_dt (N, 1) per step (computeNewVelocity, summed in the loop's order)."""
    up = vg >= v0
    steps = np.repeat(np.where(up, a_dt, -a_dt), n_steps, axis=1)
    cs = np.cumsum(np.concatenate([np.full_like(a_dt, v0), steps], axis=1), axis=1)[:, 1:]
    return np.where(up, np.minimum(vg, cs), np.maximum(vg, cs))


@dataclass
class Rollouts:
    """All samples' trajectories: cost (N,) (< 0: illegal, COLLIDES or NO_WAY), points
    x, y, th (N, S) of which the first n (N,) are the trajectory's."""

    samples: np.ndarray
    cost: np.ndarray
    x: np.ndarray
    y: np.ndarray
    th: np.ndarray
    n: np.ndarray

    def points(self, i):
        """(n, 3) poses of sample i (x [m], y [m], yaw [rad])."""
        k = int(self.n[i])
        return np.column_stack([self.x[i, :k], self.y[i, :k], self.th[i, :k]])


def _first_failure(data, n, on_map, vx, vy, no_way, centre):
    """Each trajectory's points in order, as generateTrajectory checks them, until the
    first that fails: (first (N,) index of that point, or n if none; fail (N,) COLLIDES
    or NO_WAY; occ (N,) the highest max(outline cost, centre cell cost) before it).

    on_map (N, S): the centre and the footprint's vertices on the costmap; vx, vy
    (N, S, K) vertex cells; no_way (N, S): no clear way to the plan from the point."""
    n_traj = n.shape[0]
    first = n.copy()
    fail = np.zeros(n_traj)
    occ = np.zeros(n_traj)
    for i in range(n_traj):
        for j in range(n[i]):
            fp = _outline_cost(data, vx[i, j], vy[i, j]) if on_map[i, j] else OFF_MAP
            if fp < 0:
                first[i], fail[i] = j, COLLIDES
                break
            if no_way[i, j]:
                first[i], fail[i] = j, NO_WAY
                break
            occ[i] = max(occ[i], fp, centre[i, j])
    return first, fail, occ


def first_failure(data, n, on_map, vx, vy, no_way, centre):
    """_first_failure in C: the same arguments (data the (H, W) uint8 costmap) and results."""
    data = np.ascontiguousarray(data, dtype=np.uint8)
    vx, vy = check_vertex_cells("first_failure", data, vx, vy)
    n_traj, s, k = vx.shape
    n = np.ascontiguousarray(n, dtype=np.int64)
    on_map, no_way = (np.ascontiguousarray(a, dtype=bool) for a in (on_map, no_way))
    centre = np.ascontiguousarray(centre, dtype=np.float64)
    if n.shape != (n_traj,) or on_map.shape != (n_traj, s) or no_way.shape != (n_traj, s) or \
            centre.shape != (n_traj, s):
        raise ValueError(f"first_failure: n {n.shape}, on_map {on_map.shape}, no_way {no_way.shape}, centre "
                         f"{centre.shape} for vertex cells {vx.shape}")
    if n_traj and (n.min() < 0 or n.max() > s):
        raise ValueError(f"first_failure: point counts outside 0..{s}")
    first, fail, occ = np.empty(n_traj, np.int64), np.empty(n_traj), np.empty(n_traj)
    library().snc_tp_first_failure(data, data.shape[1], n, n_traj, s, k, on_map.view(np.uint8), vx, vy,
                                   no_way.view(np.uint8), centre, first, fail, occ)
    return first, fail, occ


def rollout(cfg, pose, vel, samples, costmap, grids, polygon, biases):
    """Simulate and score every sample at once (generateTrajectory for all of them).

    pose (x, y, yaw), vel (vx, vy, vth) the robot's; samples (N, 3); grids from
    map_grids; polygon (K, 2) [m]; biases (path_distance_bias, goal_distance_bias) as
    used (scaled by the resolution with meter_scoring). Returns Rollouts.
    """
    samples = np.asarray(samples, dtype=np.float64).reshape(-1, 3)
    n = step_counts(cfg, samples)
    big_s = int(n.max())
    dt = (cfg.sim_time / n)[:, None]                            # (N, 1) [s]
    # (N, S) velocity after step i's update, the one it moves with
    vx, vy, vth = (_ramp(float(v0), samples[:, k:k + 1], a * dt, big_s)
                   for k, (v0, a) in enumerate(zip(vel, (cfg.acc_lim_x, cfg.acc_lim_y, cfg.acc_lim_theta))))
    th = np.cumsum(np.concatenate([np.full((len(samples), 1), float(pose[2])), vth[:, :-1] * dt], axis=1), axis=1)
    c, s = np.cos(th[:, :-1]), np.sin(th[:, :-1])
    x = np.cumsum(np.concatenate([np.full((len(samples), 1), float(pose[0])),
                                  (vx[:, :-1] * c - vy[:, :-1] * s) * dt], axis=1), axis=1)
    y = np.cumsum(np.concatenate([np.full((len(samples), 1), float(pose[1])),
                                  (vx[:, :-1] * s + vy[:, :-1] * c) * dt], axis=1), axis=1)
    steps = np.arange(big_s)[None, :]
    live = steps < n[:, None]
    mx, my, inside = world_to_cells(costmap, x, y)
    h, w = costmap.data.shape
    centre = costmap.data[np.clip(my, 0, h - 1), np.clip(mx, 0, w - 1)].astype(np.float64)
    cx, cy = np.clip(mx, 0, w - 1), np.clip(my, 0, h - 1)
    path_d, goal_d = grids.path[cy, cx], grids.goal[cy, cx]
    heading = np.zeros(x.shape)
    if cfg.simple_attractor:
        scored = np.zeros(x.shape, dtype=bool)
    elif cfg.heading_scoring:
        # time at step i, summed step by step as the loop does
        t = np.cumsum(np.concatenate([np.zeros((len(samples), 1)), np.repeat(dt, big_s - 1, axis=1)], axis=1),
                      axis=1)
        scored = live & (t >= cfg.heading_scoring_timestep) & (t < cfg.heading_scoring_timestep + dt)
    else:
        scored = live
    no_way = scored & ((path_d >= grids.obstacle_cost) | (goal_d >= grids.obstacle_cost))
    # The footprint outline at every point, each trajectory walked until its first failure
    vert_x, vert_y, on_map = (np.zeros(x.shape + (len(polygon),), dtype=np.int64),
                              np.zeros(x.shape + (len(polygon),), dtype=np.int64), np.zeros(x.shape, dtype=bool))
    vert_x[live], vert_y[live], on_map[live] = _vertex_cells(costmap, polygon, x[live], y[live], th[live])
    first, fail, occ = first_failure(costmap.data, n, inside & on_map, vert_x, vert_y, no_way, centre)
    rows = np.arange(len(samples))
    if cfg.heading_scoring:
        for i, j in zip(*np.nonzero(scored & (first == n)[:, None])):
            heading[i, j] = heading_diff(costmap, grids.plan, mx[i, j], my[i, j], x[i, j], y[i, j], th[i, j])
    if cfg.simple_attractor:
        last = n - 1
        gx, gy = grids.plan[-1]
        pd = np.zeros(len(samples))
        gd = (x[rows, last] - gx) ** 2 + (y[rows, last] - gy) ** 2
        hd = np.zeros(len(samples))
    else:
        # the last scored point's distances (none scored: 0)
        k = np.where(scored.any(axis=1), big_s - 1 - np.argmax(scored[:, ::-1], axis=1), -1)
        kk = np.maximum(k, 0)
        pd = np.where(k >= 0, path_d[rows, kk], 0.0)
        gd = np.where(k >= 0, goal_d[rows, kk], 0.0)
        hd = np.where(k >= 0, heading[rows, kk], 0.0)
    cost = biases[0] * pd + biases[1] * gd + cfg.occdist_scale * occ
    if cfg.heading_scoring:
        cost = cost + HEADING_WEIGHT * hd
    cost = np.where(first < n, fail, cost)
    return Rollouts(samples=samples, cost=cost, x=x, y=y, th=th, n=n)


def generate_trajectory_reference(cfg, pose, vel, sample, costmap, grids, polygon, biases):
    """One sample, step by step (generateTrajectory): (cost, (n, 3) points). Test oracle."""
    x, y, th = (float(v) for v in pose)
    vx, vy, vth = (float(v) for v in vel)
    sx, sy, sth = (float(v) for v in sample)
    n = int(step_counts(cfg, np.array([[sx, sy, sth]]))[0])
    dt = cfg.sim_time / n
    t, path_d, goal_d, occ, heading = 0.0, 0.0, 0.0, 0.0, 0.0
    pts = []

    def toward(vg, vi, a):
        return min(vg, vi + a * dt) if vg - vi >= 0 else max(vg, vi - a * dt)

    for _ in range(n):
        cell = costmap.world_to_map(x, y)
        if cell is None:
            return COLLIDES, np.array(pts).reshape(-1, 3)
        fp = footprint_cost_reference(costmap, polygon, x, y, th)
        if fp < 0:
            return COLLIDES, np.array(pts).reshape(-1, 3)
        occ = max(occ, fp, float(costmap.data[cell[1], cell[0]]))
        if cfg.simple_attractor:
            gx, gy = grids.plan[-1]
            goal_d = (x - gx) ** 2 + (y - gy) ** 2
        else:
            update = True
            if cfg.heading_scoring:
                if cfg.heading_scoring_timestep <= t < cfg.heading_scoring_timestep + dt:
                    heading = heading_diff(costmap, grids.plan, cell[0], cell[1], x, y, th)
                else:
                    update = False
            if update:
                path_d = grids.path[cell[1], cell[0]]
                goal_d = grids.goal[cell[1], cell[0]]
                if path_d >= grids.obstacle_cost or goal_d >= grids.obstacle_cost:
                    return NO_WAY, np.array(pts).reshape(-1, 3)
        pts.append((x, y, th))
        vx = toward(sx, vx, cfg.acc_lim_x)
        vy = toward(sy, vy, cfg.acc_lim_y)
        vth = toward(sth, vth, cfg.acc_lim_theta)
        c, s = np.cos(th), np.sin(th)
        x = x + (vx * c - vy * s) * dt
        y = y + (vx * s + vy * c) * dt
        th = th + vth * dt
        t += dt
    cost = biases[0] * path_d + biases[1] * goal_d + cfg.occdist_scale * occ
    if cfg.heading_scoring:
        cost += HEADING_WEIGHT * heading
    return cost, np.array(pts).reshape(-1, 3)


def rollout_reference(cfg, pose, vel, samples, costmap, grids, polygon, biases):
    """rollout's interface over generate_trajectory_reference, one sample at a time."""
    samples = np.asarray(samples, dtype=np.float64).reshape(-1, 3)
    n = step_counts(cfg, samples)
    big_s = int(n.max())
    cost = np.zeros(len(samples))
    xs, ys, ths = (np.full((len(samples), big_s), np.nan) for _ in range(3))
    for i, smp in enumerate(samples):
        cost[i], pts = generate_trajectory_reference(cfg, pose, vel, smp, costmap, grids, polygon, biases)
        k = len(pts)
        xs[i, :k], ys[i, :k], ths[i, :k] = pts[:, 0], pts[:, 1], pts[:, 2]
    return Rollouts(samples=samples, cost=cost, x=xs, y=ys, th=ths, n=n)


def heading_diff(costmap, plan, cx, cy, x, y, heading):
    """|angle| [rad] from heading to the farthest plan point in line of sight of cell
    (cx, cy) (no lethal, inscribed or unknown cell on the Bresenham line); inf if none."""
    h, w = costmap.data.shape
    for px, py in plan[::-1]:
        cell = costmap.world_to_map(px, py)
        if cell is None:
            continue
        xs, ys, valid = bresenham(cx, cy, cell[0], cell[1])
        line = costmap.data[ys[valid], xs[valid]]
        if not ((line == LETHAL_OBSTACLE) | (line == INSCRIBED_INFLATED_OBSTACLE) | (line == NO_INFORMATION)).any():
            gx, gy = costmap.map_to_world(*cell)
            return abs(wrap_angle(math.atan2(gy - y, gx - x) - heading))
    return math.inf


# -- 1. the plan ---------------------------------------------------------------------------
def window_plan(plan, pose, costmap):
    """(first, end): the plan points [first, end) transformGlobalPlan keeps: from the first
    within half the costmap's larger side of the robot to the first beyond it, included."""
    reach = max(costmap.size_x, costmap.size_y) * costmap.resolution / 2.0
    d2 = (plan[:, 0] - pose[0]) ** 2 + (plan[:, 1] - pose[1]) ** 2
    near = d2 <= reach * reach
    if not near.any():
        return 0, 0
    first = int(np.argmax(near))
    out = np.flatnonzero(~near[first:])
    end = first + int(out[0]) + 1 if out.size else len(plan)
    return first, end


# -- the planner ----------------------------------------------------------------------------
class TrajectoryPlanner(HeldPlan):
    """base_local_planner's TrajectoryPlannerROS without ROS (nav_core's BaseLocalPlanner).

    config: TrajectoryPlannerConfig; footprint: costmap.Footprint (its padded polygon is
    checked); reference: run on the per-trajectory loop and the queue wavefront (slow;
    the tests' oracle). Use as DWAPlanner: set_plan(plan, goal_yaw) per global plan,
    compute_velocity(pose, velocity, costmap) each control period, is_goal_reached().
    """

    KNOWN_PARAMS = KNOWN_PARAMS

    def __init__(self, config, footprint, reference=False):
        self.config = config
        self.footprint = footprint
        self.polygon = np.asarray(footprint.polygon, dtype=np.float64)
        self._rollout = rollout_reference if reference else rollout
        self._grid_fn = map_grid_reference if reference else map_grid
        self.notes = []        # param_reader Notes about its parameters, for the caller to log once
        self.plan = None
        self.goal_yaw = 0.0
        self.xy_latched = False
        self.goal_reached = False
        self.rotating_to_goal = False
        self.latency = config.sim_period   # [s] accepted (set_control_latency); the real planner has no use for it
        # stuck / oscillation flags and escape mode (TrajectoryPlanner's members)
        self.stuck_left = self.stuck_right = False
        self.stuck_left_strafe = self.stuck_right_strafe = False
        self.rotating_left = self.rotating_right = False
        self.strafe_left = self.strafe_right = False
        self.prev_xy = (0.0, 0.0)
        self.escaping = False
        self.escape_pose = (0.0, 0.0, 0.0)
        self.grids = None      # the last cycle's Grids (debugging, tests)

    @classmethod
    def from_params(cls, params, footprint, where="TrajectoryPlannerROS", controller_frequency=None,
                    note_where=None):
        """A planner from the TrajectoryPlannerROS parameter dict (see trajectory_planner_config);
        its .notes say what the caller should log once."""
        cfg, notes = trajectory_planner_config(params, where, controller_frequency, note_where)
        planner = cls(cfg, footprint)
        planner.notes = notes
        return planner

    # -- nav_core interface ------------------------------------------------------------
    def set_plan(self, plan, goal_yaw):
        """A new global plan: (N, 2) points [m] in the costmap frame, goal heading [rad].
        Clears the xy latch and the reached flag, as setPlan."""
        plan = np.asarray(plan, dtype=np.float64)
        if plan.ndim != 2 or len(plan) == 0 or not np.isfinite(plan[:, :2]).all() or not math.isfinite(goal_yaw):
            raise ValueError("the plan must be a non-empty list of finite points and goal_yaw finite")
        plan = plan[:, :2].copy()
        if self.plan is None or np.hypot(*(self.plan[-1] - plan[-1])) > 1e-6:
            self.rotating_to_goal = False
        self.plan = plan
        self.goal_yaw = float(goal_yaw)
        self.xy_latched = False
        self.goal_reached = False

    def is_goal_reached(self):
        return self.goal_reached

    def set_control_latency(self, seconds):
        """Accepted for DWAPlanner's interface [s]; the Trajectory Rollout planner plans for
        sim_period whatever the loop's timing, as the real one."""
        if math.isfinite(seconds):
            self.latency = float(seconds)

    def compute_velocity_commands(self, pose, velocity, costmap):
        return self.compute_velocity(pose, velocity, costmap)

    def compute_velocity(self, pose, velocity, costmap):
        """One control cycle (computeVelocityCommands).

        pose (x [m], y [m], yaw [rad]) in the costmap frame; velocity (vx [m/s], vy [m/s],
        vth [rad/s]) from odometry; costmap: the local Costmap2D. Returns a local_plan.DWAResult.
        """
        cfg = self.config
        if self.plan is None:
            return DWAResult(ok=False, reason="no plan set")
        if not all(math.isfinite(v) for v in tuple(pose) + tuple(velocity)):
            return DWAResult(ok=False, reason=f"pose {pose} or velocity {velocity} not finite")
        if self.goal_reached:
            return DWAResult(goal_reached=True, mode="goal")
        first, end = window_plan(self.plan, pose, costmap)
        local = self.plan[first:end]
        if cfg.prune_plan and len(local):
            near = np.flatnonzero((local[:, 0] - pose[0]) ** 2 + (local[:, 1] - pose[1]) ** 2
                                  < PRUNE_DIST * PRUNE_DIST)
            if near.size:
                self.plan = self.plan[first + near[0]:]
                local = local[near[0]:]
            else:
                local = local[:0]
        if len(local) == 0:
            return DWAResult(ok=False, reason=f"no point of the plan within {PRUNE_DIST} m of the robot "
                             "inside the local costmap")
        goal = self.plan[-1]
        if self.xy_latched or math.hypot(goal[0] - pose[0], goal[1] - pose[1]) <= cfg.xy_goal_tolerance:
            return self._at_goal(pose, velocity, costmap, local)
        self.grids = map_grids(costmap, local, self.polygon, pose, self._grid_fn)
        return self._find_best_path(pose, velocity, costmap)

    # -- the goal --------------------------------------------------------------------------
    def _biases(self, costmap):
        scale = costmap.resolution if self.config.meter_scoring else 1.0
        return self.config.path_distance_bias * scale, self.config.goal_distance_bias * scale

    def _legal(self, pose, velocity, cmd, costmap):
        """checkTrajectory: the command, simulated from the current velocity, has cost >= 0."""
        r = self._rollout(self.config, pose, velocity, np.array([cmd]), costmap, self.grids, self.polygon,
                          self._biases(costmap))
        return r.cost[0] >= 0

    def _at_goal(self, pose, velocity, costmap, local):
        cfg = self.config
        if cfg.latch_xy_goal_tolerance:
            self.xy_latched = True
        err = wrap_angle(self.goal_yaw - pose[2])
        if abs(err) <= cfg.yaw_goal_tolerance:
            self.rotating_to_goal = False
            self.xy_latched = False
            self.goal_reached = True
            return DWAResult(goal_reached=True, mode="goal")
        self.grids = map_grids(costmap, local, self.polygon, pose, self._grid_fn)
        dt = cfg.sim_period
        vx, vy, vth = velocity
        stopped = abs(vth) <= STOPPED_VEL and abs(vx) <= STOPPED_VEL and abs(vy) <= STOPPED_VEL
        if not self.rotating_to_goal and not stopped:
            # stopWithAccLimits: brake as hard as allowed, if that is legal
            cmd = tuple(braked(v, a, dt) for v, a in zip(velocity, (cfg.acc_lim_x, cfg.acc_lim_y, cfg.acc_lim_theta)))
            if self._legal(pose, velocity, cmd, costmap):
                return DWAResult(cmd=cmd, mode="stop")
            return DWAResult(ok=False, reason="cannot brake at the goal: the braking trajectory collides",
                             mode="stop")
        self.rotating_to_goal = True
        # rotateToGoal: toward the heading, no slower than min_in_place_vel_theta, within the
        # acceleration window and slow enough to stop at the heading
        w = rotate_to_goal_speed(err, vth, cfg.acc_lim_theta, cfg.max_vel_theta, cfg.min_vel_theta,
                                 cfg.min_in_place_vel_theta, dt)
        if self._legal(pose, velocity, (0.0, 0.0, w), costmap):
            return DWAResult(cmd=(0.0, 0.0, w), mode="rotate")
        return DWAResult(ok=False, reason="cannot rotate to the goal heading: the footprint would hit an "
                         "obstacle", mode="rotate")

    # -- sampling and choice -------------------------------------------------------------------
    def _window(self, pose, velocity):
        """(vx_lo, vx_hi, vth_lo, vth_hi): createTrajectories' velocity limits."""
        cfg = self.config
        vx, _, vth = velocity
        t = cfg.sim_period if cfg.dwa else cfg.sim_time
        end = self.grids.plan[-1]
        max_x = min(cfg.max_vel_x, math.hypot(end[0] - pose[0], end[1] - pose[1]) / cfg.sim_time)
        max_x = max(min(max_x, vx + cfg.acc_lim_x * t), cfg.min_vel_x)
        min_x = max(cfg.min_vel_x, vx - cfg.acc_lim_x * t)
        max_th = min(cfg.max_vel_theta, vth + cfg.acc_lim_theta * t)
        min_th = max(cfg.min_vel_theta, vth - cfg.acc_lim_theta * t)
        return min_x, max_x, min_th, max_th

    @staticmethod
    def _steps(lo, hi, n):
        """n values from lo by (hi - lo) / (n - 1), summed one at a time as the real loop does."""
        d = (hi - lo) / (n - 1) if n > 1 else math.inf
        vals, v = [], lo
        for _ in range(n):
            vals.append(v)
            v += d
        return np.array(vals), d

    def _find_best_path(self, pose, velocity, costmap):
        cfg = self.config
        min_x, max_x, min_th, max_th = self._window(pose, velocity)
        vxs, _ = self._steps(min_x, max_x, cfg.vx_samples)
        ths, dth = self._steps(min_th, max_th, cfg.vtheta_samples)
        if not math.isfinite(dth):
            dth = math.inf
        biases = self._biases(costmap)
        forward = []
        if not self.escaping:
            for vx in vxs:
                forward.append((vx, 0.0, 0.0))
                forward.extend((vx, 0.0, th) for th in ths[:-1])
            if cfg.holonomic_robot:
                forward += [(HOLONOMIC_DIAGONAL, HOLONOMIC_DIAGONAL, 0.0),
                            (HOLONOMIC_DIAGONAL, -HOLONOMIC_DIAGONAL, 0.0)]
        slowest = cfg.min_in_place_vel_theta   # the base cannot turn slower in place
        in_place = [(0.0, 0.0, max(th, slowest) if th > 0 else min(th, -slowest)) for th in ths]
        samples = np.array(forward + in_place, dtype=np.float64).reshape(-1, 3)
        r = self._rollout(cfg, pose, velocity, samples, costmap, self.grids, self.polygon, biases)
        n_f = len(forward)
        n_samples, n_valid = len(samples), int((r.cost >= 0).sum())
        best = None   # index into r
        if n_f:
            legal = r.cost[:n_f] >= 0
            if legal.any():
                best = int(np.argmin(np.where(legal, r.cost[:n_f], np.inf)))
        # Rotations in place: one replaces the best if no dearer (or the best strafes), the
        # one whose look-ahead point is nearest the goal, not in a direction found stuck.
        heading_dist = math.inf
        for j, th in enumerate(ths):
            i = n_f + j
            if r.cost[i] < 0 or not (best is None or r.cost[i] <= r.cost[best] or r.samples[best, 1] != 0.0):
                continue
            if not (th > dth or th < -dth):
                continue
            ahead = self._ahead_goal_dist(r, i, costmap)
            if ahead is not None and ahead < heading_dist:
                if (th < 0 and not self.stuck_left) or (th > 0 and not self.stuck_right):
                    best, heading_dist = i, ahead
        if best is not None:
            self._after_choice(pose, r.samples[best], swapped=False)
            return self._result(r, best, n_valid, n_samples)
        if cfg.holonomic_robot and len(cfg.y_vels):
            strafes = np.array([(0.0, vy, 0.0) for vy in cfg.y_vels])
            rs = self._rollout(cfg, pose, velocity, strafes, costmap, self.grids, self.polygon, biases)
            n_samples += len(strafes)
            n_valid += int((rs.cost >= 0).sum())
            sbest = None
            for i, vy in enumerate(cfg.y_vels):
                if rs.cost[i] < 0 or not (sbest is None or rs.cost[i] <= rs.cost[sbest]):
                    continue
                ahead = self._ahead_goal_dist(rs, i, costmap)
                if ahead is not None and ahead < heading_dist:
                    if (vy > 0 and not self.stuck_left_strafe) or (vy < 0 and not self.stuck_right_strafe):
                        sbest, heading_dist = i, ahead
            if sbest is not None:
                self._after_choice(pose, rs.samples[sbest], swapped=True)
                return self._result(rs, sbest, n_valid, n_samples)
        # Nothing legal: back up at escape_vel, even when the outline already touches an
        # obstacle (the real planner's rule: then every sample fails, this one too), but
        # not onto another lethal cell (not the real rule: the real planner backs into
        # it); nor where there is no way to the plan. Enter escape mode.
        rb = self._rollout(cfg, pose, velocity, np.array([(cfg.escape_vel, 0.0, 0.0)]), costmap, self.grids,
                           self.polygon, biases)
        n_samples += 1
        back = rb.points(0)
        if rb.cost[0] == NO_WAY:
            refused = "leads where no way to the plan is clear"
        elif rb.cost[0] == COLLIDES and backs_onto_obstacle(costmap, self.polygon, pose,
                                                            math.hypot(*(back[-1, :2] - pose[:2]))):
            refused = "would drive the rear onto an obstacle"
        else:
            refused = None
        # the stuck flags and escape mode follow the robot's motion whatever this cycle gives
        self._reset_stuck_if_moved(pose)
        if not self.escaping and refused is None:
            self.escape_pose = tuple(float(v) for v in pose)
            self.escaping = True
        self._maybe_end_escape(pose)
        if refused is not None:
            return DWAResult(ok=False, reason=f"no legal trajectory: of {n_samples} samples none keeps the "
                             "footprint off lethal and unknown cells with a clear way to the plan, and backing up "
                             f"at escape_vel {refused}", n_valid=0, n_samples=n_samples, mode="escape")
        cost = 1.0 if rb.cost[0] == COLLIDES else float(rb.cost[0])
        return DWAResult(cmd=(float(cfg.escape_vel), 0.0, 0.0), trajectory=back, n_valid=n_valid,
                         n_samples=n_samples, cost=cost, mode="escape")

    def _ahead_goal_dist(self, r, i, costmap):
        """Goal distance [cells] heading_lookahead ahead of sample i's end point; None off the map."""
        k = int(r.n[i]) - 1
        xe, ye, the = r.x[i, k], r.y[i, k], r.th[i, k]
        cell = costmap.world_to_map(xe + self.config.heading_lookahead * math.cos(the),
                                    ye + self.config.heading_lookahead * math.sin(the))
        return None if cell is None else float(self.grids.goal[cell[1], cell[0]])

    def _result(self, r, i, n_valid, n_samples):
        cmd = tuple(float(v) for v in r.samples[i])
        return DWAResult(cmd=cmd, trajectory=r.points(i), n_valid=n_valid, n_samples=n_samples,
                         cost=float(r.cost[i]), mode="escape" if self.escaping else ("dwa" if self.config.dwa
                                                                                      else "rollout"))

    # -- stuck flags and escape mode -----------------------------------------------------------
    def _after_choice(self, pose, cmd, swapped):
        """The stuck flags after a legal choice not driving forward. swapped: the strafing
        branch, whose bookkeeping the real planner writes with left and right swapped."""
        vx, vy, vth = cmd
        if not vx > 0:
            if vth < 0:
                self.stuck_right |= self.rotating_right
                if swapped:
                    self.rotating_left = True
                else:
                    self.rotating_right = True
            elif vth > 0:
                self.stuck_left |= self.rotating_left
                if swapped:
                    self.rotating_right = True
                else:
                    self.rotating_left = True
            elif vy > 0:
                self.stuck_right_strafe |= self.strafe_right
                if swapped:
                    self.strafe_left = True
                else:
                    self.strafe_right = True
            elif vy < 0:
                self.stuck_left_strafe |= self.strafe_left
                if swapped:
                    self.strafe_right = True
                else:
                    self.strafe_left = True
            self.prev_xy = (float(pose[0]), float(pose[1]))
        self._reset_stuck_if_moved(pose)
        self._maybe_end_escape(pose)

    def _reset_stuck_if_moved(self, pose):
        if math.hypot(pose[0] - self.prev_xy[0], pose[1] - self.prev_xy[1]) > self.config.oscillation_reset_dist:
            self.stuck_left = self.stuck_right = False
            self.stuck_left_strafe = self.stuck_right_strafe = False
            self.rotating_left = self.rotating_right = False
            self.strafe_left = self.strafe_right = False

    def _maybe_end_escape(self, pose):
        ex, ey, eth = self.escape_pose
        if (math.hypot(pose[0] - ex, pose[1] - ey) > self.config.escape_reset_dist
                or abs(wrap_angle(pose[2] - eth)) > self.config.escape_reset_theta):
            self.escaping = False
