"""move_base's executive without ROS: the PLANNING / CONTROLLING / CLEARING state machine.

Reference: ROS 1 navigation move_base (move_base.cpp: executeCb, executeCycle,
planThread; wiki.ros.org/move_base, "Expected Robot Behavior"). A goal starts in
PLANNING; a plan moves it to CONTROLLING, where the local planner gives a command every
control period. Without a plan for planner_patience [s] (or after max_planning_retries
failed attempts), without a valid command for controller_patience [s], or without
moving oscillation_distance [m] in oscillation_timeout [s], it goes to CLEARING: the
recovery behaviours run one after the other, each followed by planning again; a valid
plan (or command, or movement) for the trigger that sent it there starts the sequence
over; once they are used up the goal is aborted with move_base's text. The planner thread
makes one attempt per control cycle while PLANNING (the control loop wakes it each cycle)
and one every 1 / planner_frequency while CONTROLLING (planner_wait).

The plan is made in the global frame (map) and driven in the local one (odom). As
base_local_planner's transformGlobalPlan does every control cycle, the plan the local
planner holds is re-expressed with the current global -> local transform whenever it
moved (amcl correcting map -> odom while the robot drives), so the goal stays where it
is in the map whether or not a new plan comes.

MoveBaseCore is pure: time comes in as seconds, poses as (x, y, yaw), plugins (nav_core
shapes) are passed in, and each control cycle returns what to publish and log. It is not
thread-safe: the node calls it under one lock from its control loop and planner thread.
Also here: the checks of a goal before it is accepted (accept_goal; GoalError with the
abort text), and the ~make_plan service's planning (service_plan).
"""
import collections
import math
from dataclasses import dataclass, field

import numpy as np

from summit_nav_common.geometry import compose, inverse

from .cost_values import FREE_SPACE, INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION
from .latency import LatencyMeter

PLANNING, CONTROLLING, CLEARING = "PLANNING", "CONTROLLING", "CLEARING"
# What sent move_base to CLEARING, and the abort text when the recoveries are used up
# (move_base's own texts, with the last failure appended).
PLANNING_R, CONTROLLING_R, OSCILLATION_R = "planning", "controlling", "oscillation"
RECOVERY_FAILED = {
    PLANNING_R: "Failed to find a valid plan. Even after executing recovery behaviors.",
    CONTROLLING_R: "Failed to find a valid control. Even after executing recovery behaviors.",
    OSCILLATION_R: "Robot is oscillating. Even after executing recovery behaviors.",
}
TRAIL_STEP = 0.02            # [m] between the trail points kept for back_up
TRAIL_POINTS = 250           # the last 5 m of them
QUATERNION_TOLERANCE = 1e-2  # |norm - 1| accepted in a goal's orientation [-]
UPRIGHT_TOLERANCE = 1e-3     # 1 - cos(tilt) accepted: a goal may only rotate about z [-]
INVALID_GOAL = "Aborting on goal because it was sent with an invalid goal: "   # + GoalError's text
WARN, INFO = "warn", "info"
FRAME_MOVED = 1e-9           # [m, rad] a global -> local transform change below this is none


class GoalError(ValueError):
    """A goal that cannot be driven to; the text is the abort reason."""


# -- goal checks ---------------------------------------------------------------------------
def check_goal_pose(position, orientation):
    """GoalError when a goal's position (x, y, z) or quaternion (x, y, z, w) has NaN/inf,
    or the quaternion is not of unit length or not a rotation about z (move_base's
    isQuaternionValid)."""
    if not all(math.isfinite(v) for v in tuple(position) + tuple(orientation)):
        raise GoalError(f"goal has a NaN or infinite value: position {tuple(position)}, "
                        f"orientation {tuple(orientation)}")
    qx, qy, qz, qw = orientation
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise GoalError(f"goal orientation is not a unit quaternion (length {norm:.4f})")
    # the z axis of the rotated frame must stay vertical
    if 1.0 - 2.0 * (qx * qx + qy * qy) < 1.0 - UPRIGHT_TOLERANCE:
        raise GoalError("goal orientation is not a rotation about z (roll/pitch not zero)")


def nearest_free_cell(costmap, wx, wy, tolerance, allow_unknown):
    """World (x, y) of the free cell nearest (wx, wy) within tolerance [m], or None.

    Free: cost below INSCRIBED (and not unknown unless allow_unknown), as NavFn passes.
    """
    cell = costmap.world_to_map(wx, wy)
    r = int(math.ceil(tolerance / costmap.resolution))
    x0, y0 = max(0, cell[0] - r), max(0, cell[1] - r)
    x1, y1 = min(costmap.size_x, cell[0] + r + 1), min(costmap.size_y, cell[1] + r + 1)
    sub = costmap.data[y0:y1, x0:x1]
    ok = sub < INSCRIBED_INFLATED_OBSTACLE
    if allow_unknown:
        ok |= sub == NO_INFORMATION
    yy, xx = np.mgrid[y0:y1, x0:x1]
    cx = costmap.origin_x + (xx + 0.5) * costmap.resolution
    cy = costmap.origin_y + (yy + 0.5) * costmap.resolution
    d = np.where(ok, np.hypot(cx - wx, cy - wy), np.inf)
    k = int(np.argmin(d))
    if not d.flat[k] <= tolerance:
        return None
    return float(cx.flat[k]), float(cy.flat[k])


def cost_name(cost):
    return {LETHAL_OBSTACLE: "in an obstacle (lethal cell)",
            INSCRIBED_INFLATED_OBSTACLE: "too close to an obstacle (inscribed cell)",
            NO_INFORMATION: "in unknown space"}.get(cost, f"in a cell of cost {cost}")


def check_goal_cell(costmap, goal, allow_unknown, tolerance, frame="map"):
    """The goal (x, y, yaw) to drive to on the global costmap: as given when its cell is
    free, else the nearest free cell within tolerance [m]; GoalError when it is off the
    costmap or blocked with no free cell near. Returns (goal, moved)."""
    cell = costmap.world_to_map(goal[0], goal[1])
    if cell is None:
        w, h = costmap.size_in_meters
        raise GoalError(f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is off the map: the global costmap spans "
                        f"x {costmap.origin_x:.2f}..{costmap.origin_x + w:.2f}, y {costmap.origin_y:.2f}.."
                        f"{costmap.origin_y + h:.2f} m in frame '{frame}'")
    cost = int(costmap.data[cell[1], cell[0]])
    if cost < INSCRIBED_INFLATED_OBSTACLE or (cost == NO_INFORMATION and allow_unknown):
        return tuple(goal), False
    free = nearest_free_cell(costmap, goal[0], goal[1], tolerance, allow_unknown) if tolerance > 0 else None
    if free is None:
        raise GoalError(f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is {cost_name(cost)} of the global "
                        f"costmap and no free cell lies within default_tolerance {tolerance:.2f} m")
    return (free[0], free[1], goal[2]), True


def blocked_by_map(static_grids, goal, inscribed_radius, allow_unknown):
    """True when the map itself blocks the goal (x, y [m]): off a static layer's grid
    (Costmap2D, same frame), a lethal cell of it within inscribed_radius [m], or the goal
    cell unknown while allow_unknown is false. False when only what the sensors marked blocks
    it: the real move_base accepts such a goal and plans (its recoveries clear marks), so a
    laser's passing phantom point must not abort a goal at once."""
    for grid in static_grids:
        cell = grid.world_to_map(goal[0], goal[1])
        if cell is None:
            return True
        if not allow_unknown and int(grid.data[cell[1], cell[0]]) == NO_INFORMATION:
            return True
        r = int(math.ceil(inscribed_radius / grid.resolution))
        x0, y0 = max(0, cell[0] - r), max(0, cell[1] - r)
        x1, y1 = min(grid.size_x, cell[0] + r + 1), min(grid.size_y, cell[1] + r + 1)
        yy, xx = np.nonzero(grid.data[y0:y1, x0:x1] == LETHAL_OBSTACLE)
        cx = grid.origin_x + (xx + x0 + 0.5) * grid.resolution
        cy = grid.origin_y + (yy + y0 + 0.5) * grid.resolution
        if np.any(np.hypot(cx - goal[0], cy - goal[1]) <= inscribed_radius):
            return True
    return False


def service_plan(planner, costmap, robot, start, goal, tolerance, clearing_radius=None,
                 add_unreachable_goal=True):
    """move_base's ~make_plan (planService): the path (N, 2) [m] from start to goal
    (x, y, yaw) on costmap (a Costmap2D, left unchanged).

    As move_base: a plan to the goal as the planner makes it (its own default_tolerance);
    failing that, with tolerance [m] > 0 (the request's), a plan to a free cell within
    tolerance of the goal (ours: the planner's nearest-cell search, where move_base tries
    offsets on a grid of 3 cells), with the goal itself appended when
    add_unreachable_goal (make_plan_add_unreachable_goal), "in case the local planner can
    get you there". clearing_radius [m] (make_plan_clear_costmap; move_base's
    ~clearing_radius): plan as if the square of half-side clearing_radius around robot
    (x, y, yaw) were free space; the real move_base frees it in its live costmaps, where
    it can outlast the request, ours in a copy. None: plan on the costmap as it is.
    GoalError with the planner's reason when there is no path.
    """
    if clearing_radius is not None and robot is not None:
        costmap = _with_free_square(costmap, robot, clearing_radius)
    r = planner.make_plan(costmap, start, goal)
    if r.ok:
        return np.asarray(r.path, dtype=np.float64).reshape(-1, 2)
    if tolerance > 0.0:
        near = planner.make_plan(costmap, start, goal, tolerance)
        if near.ok:
            path = np.asarray(near.path, dtype=np.float64).reshape(-1, 2)
            if add_unreachable_goal:
                path = np.vstack([path, [goal[0], goal[1]]])
            return path
    raise GoalError(r.reason)


def _with_free_square(costmap, centre, half_side):
    """A copy of costmap with the cells of the square of half_side [m] around centre
    (x, y) set to free space (move_base's clearCostmapWindows)."""
    out = costmap.copy()
    x0, y0 = costmap.world_to_map_no_bounds(centre[0] - half_side, centre[1] - half_side)
    x1, y1 = costmap.world_to_map_no_bounds(centre[0] + half_side, centre[1] + half_side)
    x0, y0 = max(0, x0), max(0, y0)
    x1, y1 = min(costmap.size_x - 1, x1), min(costmap.size_y - 1, y1)
    if x1 >= x0 and y1 >= y0:
        out.data[y0:y1 + 1, x0:x1 + 1] = FREE_SPACE
    return out


def accept_goal(costmap, static_grids, goal, allow_unknown, tolerance, inscribed_radius, frame="map"):
    """The goal (x, y, yaw) move_base drives to, checked on the global costmap (Costmap2D)
    when it arrives: as given when its cell is free; moved to the nearest free cell within
    tolerance [m] (the global planner's default_tolerance); as given when only what the
    sensors marked blocks it (the static layers' grids, static_grids, leave it free:
    blocked_by_map within inscribed_radius [m]). GoalError (the abort text after
    INVALID_GOAL) when it is off the costmap or the map blocks it. Returns (goal, note):
    note, what to log about the goal ('' when nothing)."""
    try:
        checked, moved = check_goal_cell(costmap, goal, allow_unknown, tolerance, frame)
    except GoalError as e:
        if not static_grids or blocked_by_map(static_grids, goal, inscribed_radius, allow_unknown):
            raise
        return tuple(goal), (f"{e}; the map leaves it free, so it is planned to as given "
                             f"(obstacles the sensors marked may move or be cleared)")
    if moved:
        return checked, (f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is blocked; driving to the nearest free cell "
                         f"({checked[0]:.2f}, {checked[1]:.2f})")
    return checked, ""


# -- the state machine ---------------------------------------------------------------------
@dataclass
class CycleOutput:
    """What one control cycle asks the node to do.

    cmd: (vx, vy, vth) to publish, or None: publish a stop; end: (how, text) when the goal
    ends ('succeeded' or 'aborted'); trajectory: the local planner's chosen trajectory
    ((T, 3), local frame) or None; local_plan: the global plan as just handed to the
    local planner ((N, 2), local frame) or None; dump: the controller's patience ran out
    (the node may save its inputs); recovery: (index from 0, count, name) when a
    recovery behaviour starts this cycle (move_base's recovery_status), else None; logs:
    [(level, text, throttled)] to log.
    """

    cmd: tuple = None
    end: tuple = None
    trajectory: object = None
    local_plan: object = None
    dump: bool = False
    recovery: tuple = None
    logs: list = field(default_factory=list)


class MoveBaseCore:
    """move_base's decisions for one goal at a time.

    config: params.MoveBaseConfig (planner_frequency, *_patience, oscillation_*,
    max_planning_retries, recovery_behavior_enabled); make_local_planner(): a fresh local
    planner (nav_core.LocalPlanner) for each goal; recoveries: [(name, behaviour)] in
    order (nav_core.RecoveryBehavior).

    Use: start_goal(goal, now) for each new goal (it preempts the active one); the
    planner thread waits planner_wait() (wait_for_plan_request), takes the request with
    begin_plan() and reports on_plan(); the control loop calls cycle() every period,
    notifies the planner thread while run_planner and publishes its CycleOutput; stop()
    when the goal ends.
    """

    def __init__(self, config, make_local_planner, recoveries):
        self.config = config
        self.make_local_planner = make_local_planner
        self.recoveries = list(recoveries)
        self.local_planner = None
        self.goal = None
        self.goal_id = 0
        # where the robot's centre has been (local frame), for back_up
        self.trail = collections.deque(maxlen=TRAIL_POINTS)
        # control-loop latency over the last second of cycles, for the local planner's braking
        self.latency = LatencyMeter(round(config.controller_frequency))
        self._reset(None, 0.0)

    def _reset(self, goal, now):
        self.goal = goal                    # (x, y, yaw) in the global frame, or None
        self.state = PLANNING
        self.trigger = PLANNING_R           # what last sent (or would send) it to CLEARING
        self.failure = ""                   # why it last went to CLEARING
        self.run_planner = goal is not None
        self.planner_wake = goal is not None   # a control-loop wake not yet used by an attempt
        self.next_replan = now              # [s] CONTROLLING: the planner_frequency attempt is due
        self.new_plan = None                # (N, 2) global plan not yet given to the controller
        self.has_plan = False               # the controller has a plan
        self.plan_frame = None              # the global -> local transform it was expressed with
        self.planning_retries = 0
        self.recovery_index = 0
        self.recovery_running = None        # index of the behaviour started, or None
        self.last_valid_plan = now
        self.last_valid_control = now
        self.last_oscillation_reset = now
        self.oscillation_pose = None

    # -- goals ------------------------------------------------------------------------
    def start_goal(self, goal, now):
        """Drive to goal (x, y, yaw) in the global frame from now [s]; replaces any goal."""
        self.goal_id += 1
        self.local_planner = self.make_local_planner()   # no latch or reached flag carried over
        self._reset(tuple(goal), now)
        self.latency.reset()

    def stop(self):
        """The goal ended (or was preempted): nothing is driven or planned."""
        self.goal = None
        self.run_planner = False

    @property
    def active(self):
        return self.goal is not None

    # -- the planner thread's side --------------------------------------------------------
    def plan_request(self):
        """(goal_id, goal) to plan for now, or None when no plan is wanted."""
        if self.goal is None or not self.run_planner:
            return None
        return self.goal_id, self.goal

    def on_plan(self, goal_id, path, reason, now):
        """A planning attempt for goal_id ended at now [s]: path (N, 2) in the global frame,
        or None with the planner's reason. Returns [(level, text, throttled)] to log."""
        if goal_id != self.goal_id or self.goal is None:
            return []   # a plan for a goal since replaced
        if path is not None:
            self.new_plan = path
            self.last_valid_plan = now
            self.planning_retries = 0
            if self.config.planner_frequency <= 0:
                self.run_planner = False   # plan once per goal
            return []
        if self.state != PLANNING:
            return []   # replanning while driving: keep the plan it has
        self.planning_retries += 1
        logs = [(WARN, f"no plan to the goal: {reason}", True)]
        mr = self.config.max_planning_retries
        if now - self.last_valid_plan > self.config.planner_patience or (mr >= 0 and self.planning_retries > mr):
            self._to_clearing(PLANNING_R, reason)
            logs.append((WARN, f"no plan for {self.config.planner_patience} s or {self.planning_retries} "
                               f"attempts ({reason}): starting recoveries", False))
        return logs

    def planner_wait(self, now):
        """[s] the planner thread waits from now [s] before its next attempt: 0 to plan now,
        math.inf until the control loop wakes it (or a new goal).

        move_base's planThread: while PLANNING, one attempt per wake, and the control loop
        wakes it once per cycle (and a new goal once), so a planner that keeps failing is
        tried once per control cycle, never back to back; while CONTROLLING, an attempt
        1 / planner_frequency after the last one began (planner_frequency 0: no replanning,
        run_planner is off). Nothing to plan: math.inf."""
        if self.plan_request() is None:
            return math.inf
        if self.state == PLANNING:
            return 0.0 if self.planner_wake else math.inf
        return max(0.0, self.next_replan - now)

    def begin_plan(self, now):
        """The planner thread starts an attempt at now [s]: (goal_id, goal) to plan for (as
        plan_request), the wake it answers used up and the next planner_frequency attempt
        timed from now; None when no plan is wanted."""
        request = self.plan_request()
        if request is not None:
            self.planner_wake = False
            if self.config.planner_frequency > 0:
                self.next_replan = now + 1.0 / self.config.planner_frequency
        return request

    def _to_clearing(self, trigger, failure):
        self.state, self.trigger, self.failure = CLEARING, trigger, failure
        self.run_planner = False

    def _to_planning(self, now):
        self.state = PLANNING
        self.run_planner = True
        self.last_valid_plan = now
        self.planning_retries = 0

    # -- the control loop's side ----------------------------------------------------------
    def cycle(self, now, global_pose, local_pose, velocity, costmap, global_to_local):
        """One control cycle (move_base's executeCycle) at now [s].

        global_pose, local_pose: the robot's (x, y, yaw) in the global and local frames
        (None when unknown: the robot is stopped); velocity (vx, vy, vth) from odometry;
        costmap: the local Costmap2D (held still by the caller); global_to_local: the
        global frame's pose in the local frame, or None when unknown. A cycle that leaves
        the goal waiting for a plan wakes the planner thread for one attempt (planner_wait).
        """
        out = self._cycle(now, global_pose, local_pose, velocity, costmap, global_to_local)
        if self.goal is not None and self.run_planner and self.state == PLANNING:
            self.planner_wake = True
        return out

    def _cycle(self, now, global_pose, local_pose, velocity, costmap, global_to_local):
        out = CycleOutput()
        if self.goal is None or global_pose is None or local_pose is None:
            return out
        if not self.trail or math.hypot(local_pose[0] - self.trail[-1][0],
                                        local_pose[1] - self.trail[-1][1]) >= TRAIL_STEP:
            self.trail.append((local_pose[0], local_pose[1]))
        latency = self.latency.update(now)
        if latency is not None:
            self.local_planner.set_control_latency(latency)
        # Not while a recovery runs: the real move_base runs one to its end before the
        # next cycle, and back_up moves the robot.
        if self.state != CLEARING and (
                self.oscillation_pose is None
                or math.hypot(global_pose[0] - self.oscillation_pose[0], global_pose[1] - self.oscillation_pose[1])
                >= self.config.oscillation_distance):
            self.last_oscillation_reset = now
            self.oscillation_pose = tuple(global_pose)
            if self.trigger == OSCILLATION_R:
                self.recovery_index = 0
        new_plan, self.new_plan = self.new_plan, None
        if new_plan is not None:
            if self.trigger == PLANNING_R:
                self.recovery_index = 0   # a valid plan again
            out.local_plan = self._give_plan(new_plan, global_to_local, out)
            if self.state == PLANNING:
                self.state = CONTROLLING
            if self.config.planner_frequency <= 0:
                self.run_planner = False
        elif self.has_plan:
            self._follow_frame(global_to_local, out)
        if self.state == PLANNING:
            self.run_planner = True
            return out
        if self.state == CONTROLLING:
            return self._control(now, global_pose, local_pose, velocity, costmap, out)
        return self._clear(now, local_pose, velocity, costmap, out)

    def _give_plan(self, plan, global_to_local, out):
        """The global plan into the local frame, handed to the local planner."""
        if global_to_local is None:
            out.logs.append((WARN, "cannot put the plan into the local frame: no transform", True))
            return None
        x, y, yaw = global_to_local
        c, s = math.cos(yaw), math.sin(yaw)
        plan = np.asarray(plan, dtype=np.float64)
        local = np.column_stack([x + c * plan[:, 0] - s * plan[:, 1], y + s * plan[:, 0] + c * plan[:, 1]])
        self.local_planner.set_plan(local, self.goal[2] + yaw)
        self.has_plan = True
        self.plan_frame = tuple(float(v) for v in global_to_local)
        return local

    def _follow_frame(self, global_to_local, out):
        """transformGlobalPlan each cycle: when the global -> local transform moved since the
        plan was expressed, the local planner re-expresses its plan by the change
        (nav_core.LocalPlanner.reframe_plan); its pruning and goal latch are kept."""
        if global_to_local is None:
            out.logs.append((WARN, "cannot follow the global frame: no transform; the plan stays as it was "
                                   "last expressed", True))
            return
        new = tuple(float(v) for v in global_to_local)
        delta = compose(new, inverse(self.plan_frame))
        if max(abs(v) for v in delta) <= FRAME_MOVED:
            return
        self.local_planner.reframe_plan(tuple(float(v) for v in delta))
        self.plan_frame = new

    def _control(self, now, global_pose, local_pose, velocity, costmap, out):
        cfg = self.config
        if not self.has_plan:
            self.state = PLANNING
            return out
        if cfg.oscillation_timeout > 0 and now - self.last_oscillation_reset > cfg.oscillation_timeout:
            self._to_clearing(OSCILLATION_R, f"it did not move {cfg.oscillation_distance} m in "
                                             f"{cfg.oscillation_timeout} s")
            out.logs.append((WARN, f"the robot has not moved {cfg.oscillation_distance} m in "
                                   f"{cfg.oscillation_timeout} s: oscillating, starting recoveries", False))
            return out
        res = self.local_planner.compute_velocity_commands(local_pose, velocity, costmap)
        if self.local_planner.is_goal_reached():
            g, p = self.goal, global_pose
            out.end = ("succeeded", f"Goal reached: robot at ({p[0]:.2f}, {p[1]:.2f}, yaw {p[2]:.2f}), "
                                    f"{math.hypot(p[0] - g[0], p[1] - g[1]):.3f} m from the goal")
            return out
        out.trajectory = getattr(res, "trajectory", None)
        if res.ok:
            out.cmd = tuple(res.cmd)
            self.last_valid_control = now
            if self.trigger == CONTROLLING_R:
                self.recovery_index = 0
            return out
        if now - self.last_valid_control > cfg.controller_patience:
            self._to_clearing(CONTROLLING_R, res.reason)
            out.dump = True
            out.logs.append((WARN, f"no valid command for {cfg.controller_patience} s ({res.reason}): "
                                   f"starting recoveries", False))
        else:
            # as move_base: without a valid command, plan again
            self._to_planning(now)
            out.logs.append((WARN, f"the local planner found no valid command: {res.reason}; planning again",
                             True))
        return out

    def _clear(self, now, local_pose, velocity, costmap, out):
        """CLEARING: the next recovery behaviour a step; abort when none is left."""
        idx, n = self.recovery_index, len(self.recoveries)
        if not self.config.recovery_behavior_enabled or idx >= n:
            detail = f" Last failure: {self.failure}" if self.failure else ""
            off = "" if self.config.recovery_behavior_enabled else " (recovery_behavior_enabled is false)"
            out.end = ("aborted", RECOVERY_FAILED[self.trigger] + detail + off)
            return out
        name, beh = self.recoveries[idx]
        if self.recovery_running != idx:
            out.logs.append((WARN, f"recovery behaviour {idx + 1}/{n}: {name}", False))
            out.recovery = (idx, n, name)
            self.recovery_running = idx
            beh.start(local_pose, trail=list(self.trail))   # back up only where it has been
        step = beh.step(local_pose, velocity, costmap)
        if step.reason:
            out.logs.append((WARN, f"{name}: {step.reason}", False))
        if not step.done:
            out.cmd = tuple(step.cmd)
            return out
        self.recovery_index += 1
        self.recovery_running = None
        self._to_planning(now)
        self.last_valid_control = now
        self.last_oscillation_reset = now
        return out


def wait_for_plan_request(core, cv, clock, running, idle):
    """The planner thread's wait for its next attempt (move_base's planThread): under cv
    (a threading.Condition over the lock that guards core, notified by the control loop
    every cycle while core.run_planner and at each new goal), wait what core.planner_wait
    says, at most idle [s] of wall time at once so running() and the clock (clock():
    now [s], ROS time) are looked at again; then core.begin_plan. Returns its
    (goal_id, goal), or None once running() is false."""
    with cv:
        while running():
            wait = core.planner_wait(clock())
            if wait <= 0.0:
                return core.begin_plan(clock())
            cv.wait(min(wait, idle))
    return None


class RateWatch:
    """"Control loop missed its desired rate", said once with the measured cycle time
    rather than every late cycle: update(took) returns the text the first time a cycle
    takes longer than 1 / frequency [s], else None."""

    def __init__(self, frequency):
        self.frequency = float(frequency)
        self.said = False

    def update(self, took):
        if self.said or self.frequency <= 0 or took <= 1.0 / self.frequency:
            return None
        self.said = True
        return (f"Control loop missed its desired rate of {self.frequency:.4f}Hz... the loop actually took "
                f"{took:.4f} seconds (said once; the local planner brakes for the measured delay)")
