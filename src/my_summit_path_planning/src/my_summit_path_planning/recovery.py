"""move_base's recovery behaviours: clear the costmaps, rotate in place, move slowly, back up.

Reference: ROS 1 navigation ``clear_costmap_recovery`` (reset_distance, layer_names,
clearing the layer *outside* a reset_distance square centred on the robot),
``rotate_recovery`` (a full turn in place at a speed bounded by the acceleration needed
to stop, aborted when the footprint would hit something) and ``move_slow_and_clear``
(free the cells *inside* a square around the robot, then cap the local planner's speeds
through its dynamic_reconfigure server until the robot has moved a short way). move_base's default sequence
and its ``recovery_behaviors`` list are loaded by type string in plugins.py. Our
additions to the types are back_up (``my_summit_path_planning/BackUpRecovery``, after Navigation2's BackUp
behaviour): drive straight back a short way, checking the footprint behind; and
turn_around (``my_summit_path_planning/TurnAroundRecovery``): a several-point turn out of
a pocket, found by a uniform-cost search over short forward, backward and turning moves
(the lattice of a state-lattice planner, Pivtoraiko & Kelly 2005, in its smallest form),
then driven move by move.

Pure: a recovery gets its costmaps, pose and velocity passed in and returns commands;
the node publishes them. Each behaviour has the same small shape (nav_core.RecoveryBehavior):
``start(pose, trail)``, then ``step(pose, velocity, costmap) -> RecoveryStep`` until
``done``.
"""
import heapq
import math
from dataclasses import dataclass

import numpy as np

from .clearance import ClearancePolicy, footprint_checks, footprint_clearance, obstacle_distance
from summit_nav_common.geometry import wrap_angle

DEFAULT_LAYER_NAMES = ("obstacles",)      # clear_costmap_recovery's default layer_names
AFFECTED_MAPS = ("local", "global", "both")  # clear_costmap_recovery's affected_maps values
AGGRESSIVE_RADIUS_FACTOR = 4.0            # move_base: aggressive reset_distance = 4 x circumscribed radius
FULL_TURN = 2.0 * math.pi                 # [rad]


@dataclass
class RecoveryStep:
    """One step of a recovery: cmd (vx, vy, vth); done; ok False when it had to give up."""

    cmd: tuple = (0.0, 0.0, 0.0)
    done: bool = False
    ok: bool = True
    reason: str = ""


def named_layers(layered, layer_names):
    """The layers of a LayeredCostmap clear_costmap_recovery's layer_names names (by the
    name after the last "/", as costmap_2d's plugin names go)."""
    return [l for l in layered.layers if l.name.rsplit("/", 1)[-1] in layer_names]


def nothing_cleared_notes(costmaps, clears, rule):
    """One note for each costmap handle in which clears(layered) finds no layer: a clearing
    behaviour that will clear nothing there (rule: what it clears, for the note)."""
    out = []
    for c in costmaps:
        if c is not None and not clears(c.layered):
            names = ", ".join(l.name for l in c.layered.layers)
            out.append(f"{rule}, and {getattr(c, 'name', 'a costmap')} has none ({names}): "
                       f"it will clear nothing there")
    return out


def clear_costmap_layers(layered, robot_xy, reset_distance, layer_names=DEFAULT_LAYER_NAMES,
                         force_clear_all=False, invert=False):
    """Clear obstacle layers outside (invert: inside) a reset_distance [m] square centred
    on the robot.

    layered: LayeredCostmap; robot_xy (x, y) [m] in its frame; layer_names: the layers
    to clear, by the name after the last "/" (missing names are skipped, as
    clear_costmap_recovery goes on); force_clear_all: clear the whole layer
    (reset_distance ignored; ours). Returns the names of the layers cleared. The master
    grid is rebuilt at the next update_map.
    """
    cleared = []
    m = layered.master
    half = 0.5 * float(reset_distance)
    x0, y0 = m.world_to_map_no_bounds(robot_xy[0] - half, robot_xy[1] - half)
    x1, y1 = m.world_to_map_no_bounds(robot_xy[0] + half, robot_xy[1] + half)
    for layer in named_layers(layered, layer_names):
        if not hasattr(layer, "clear_window"):
            continue
        if force_clear_all:
            layer.reset()
        else:
            # the square's inside is the cells strictly between its corner cells, as in
            # costmap_2d's clearArea; clear_window's invert clears outside it (the default)
            layer.clear_window((x0 + 1, y0 + 1, x1, y1), invert=not invert)
        cleared.append(layer.name)
    # The master is redrawn whole at the next update_map, so cleared cells vanish.
    layered.force_full_update = True
    return cleared


class ClearCostmapRecovery:
    """clear_costmap_recovery: clear the costmaps' obstacle layers outside a
    reset_distance [m] square centred on the robot, in one step.

    global_costmap, local_costmap: costmap handles (``layered``, ``lock``,
    ``get_robot_pose()``, ``update()``; see nav_core.PluginContext) or None; each is
    cleared around the robot's pose in its own frame. The real node's parameters:
    layer_names (default [obstacles]: a layer named otherwise, such as the course's
    obstacle_layer, is not cleared unless named), invert_area_to_clear (clear inside the
    square instead), affected_maps ("local", "global" or "both"), force_updating (rebuild
    the costmap at once instead of at its next update); ours: force_clear_all (clear the
    layers whole).
    """

    def __init__(self, global_costmap, local_costmap, reset_distance=3.0,
                 layer_names=DEFAULT_LAYER_NAMES, force_clear_all=False, invert_area_to_clear=False,
                 affected_maps="both", force_updating=False):
        chosen = {"global": (global_costmap,), "local": (local_costmap,)}.get(
            affected_maps, (global_costmap, local_costmap))
        self.costmaps = [c for c in chosen if c is not None]
        self.reset_distance = reset_distance
        self.layer_names = tuple(layer_names)
        self.force_clear_all = force_clear_all
        self.invert = invert_area_to_clear
        self.force_updating = force_updating
        self.cleared = []

    def clearing_notes(self):
        """Why this behaviour would clear nothing in a costmap (said once at start): the
        layer_names default, [obstacles], misses layers named otherwise, in the real node
        too, which only logs the names it will clear."""
        return nothing_cleared_notes(self.costmaps, lambda layered: named_layers(layered, self.layer_names),
                                     f"clear_costmap_recovery clears the layers named {list(self.layer_names)} "
                                     f"(layer_names)")

    def start(self, pose, trail=()):
        """Nothing to prepare: the clearing is one step."""

    def step(self, pose, velocity=None, costmap=None):
        """Clear each costmap around the robot's pose in it; done at once."""
        self.cleared, missed = [], []
        for c in self.costmaps:
            robot = c.get_robot_pose()
            if robot is None:
                missed.append(getattr(c, "name", "a costmap"))
                continue
            with c.lock:
                self.cleared += clear_costmap_layers(c.layered, robot[:2], self.reset_distance,
                                                     self.layer_names, self.force_clear_all, self.invert)
            if self.force_updating and hasattr(c, "update"):
                c.update()
        reason = f"clear costmap: no robot pose in {', '.join(missed)}: not cleared" if missed else ""
        return RecoveryStep(done=True, reason=reason)


FREE_SPACE = 0
SLOW_LAYER_MARK = "obstacles"   # move_slow_and_clear clears the layers whose name contains it


def slow_clearing_layers(layered):
    """The layers move_slow_and_clear clears in a LayeredCostmap: those whose name contains
    "obstacles" (its rule; costmap_2d's own names, obstacle_layer among them, do not)."""
    return [l for l in layered.layers if SLOW_LAYER_MARK in l.name and hasattr(l, "set_window_cost")]


class MoveSlowAndClear:
    """move_slow_and_clear: free the cells around the robot, then creep until it has moved.

    In its one step: in the global and the local costmap, every layer whose name contains
    "obstacles" gets FREE_SPACE in the square of half-side clearing_distance [m] centred on
    the robot (nothing in a costmap where a corner of the square is off it); then the
    local planner's ``max_trans_param_name`` and ``max_rot_param_name`` are set to
    limited_trans_speed [m/s] and limited_rot_speed [rad/s] through its
    dynamic_reconfigure server (~planner_namespace/set_parameters), the values before
    the limit kept from the parameter server. tick(), called periodically by the node
    (the real one's 10 Hz timer), puts those values back once the robot is
    limited_distance [m] from where the limit began (global frame). A second run while
    limited keeps the first run's values to restore.

    The defaults are the real one's, max_trans_vel and max_rot_vel: DWAPlannerROS's old
    names, which its dynamic_reconfigure server no longer has (max_vel_trans and
    max_vel_theta now; TrajectoryPlannerROS: max_vel_x and max_vel_theta), so with them
    the speeds are not limited and the missing names are logged, as in the real one.

    planner_params: the node's access to the planners' parameters, get(namespace, name)
    -> value or None and set(namespace, {name: value}); None: speeds are not limited.
    """

    def __init__(self, global_costmap, local_costmap, planner_params=None, clearing_distance=0.5,
                 limited_trans_speed=0.25, limited_rot_speed=0.45, limited_distance=0.3,
                 max_trans_param_name="max_trans_vel", max_rot_param_name="max_rot_vel",
                 planner_namespace="DWAPlannerROS"):
        self.global_costmap, self.local_costmap = global_costmap, local_costmap
        self.planner_params = planner_params
        self.clearing_distance = float(clearing_distance)
        self.limits = {max_trans_param_name: float(limited_trans_speed), max_rot_param_name: float(limited_rot_speed)}
        self.limited_distance = float(limited_distance)
        self.namespace = planner_namespace
        self.limit_set = False
        self.old = {}               # the planner's values to restore, by name
        self.limit_pose = None      # (x, y) in the global frame where the limit began
        self.cleared = []

    def clearing_notes(self):
        """Why this behaviour would clear nothing in a costmap (said once at start)."""
        return nothing_cleared_notes((self.global_costmap, self.local_costmap), slow_clearing_layers,
                                     f"move_slow_and_clear clears only layers whose name contains "
                                     f"'{SLOW_LAYER_MARK}'")

    def start(self, pose, trail=()):
        """Nothing to prepare: the behaviour is one step."""

    def step(self, pose, velocity=None, costmap=None):
        """Clear around the robot and set the speed limits; done at once."""
        notes, self.cleared, poses = [], [], {}
        for c in (self.global_costmap, self.local_costmap):
            if c is None:
                continue
            robot = poses[id(c)] = c.get_robot_pose()
            if robot is None:
                notes.append(f"no robot pose in {getattr(c, 'name', 'a costmap')}: not cleared")
                continue
            with c.lock:
                self.cleared += self._clear(c.layered, robot)
        if self.planner_params is None:
            notes.append("no access to the planners' parameters: speeds not limited")
            return RecoveryStep(done=True, reason="; ".join(notes))
        if not self.limit_set:
            self.old = {}
            for name in self.limits:
                value = self.planner_params.get(self.namespace, name)
                if value is None:
                    notes.append(f"The planner ~{self.namespace}, does not have the parameter {name}")
                else:
                    self.old[name] = value
        g = poses.get(id(self.global_costmap))     # None: tick() starts from its first pose
        self.limit_pose = None if g is None else (g[0], g[1])
        self.planner_params.set(self.namespace, dict(self.limits))
        self.limit_set = True
        notes.append("Recovery setting " + ", ".join(f"{k} {v:g}" for k, v in self.limits.items())
                     + f" until the robot has moved {self.limited_distance:g} m")
        return RecoveryStep(done=True, reason="; ".join(notes))

    def _clear(self, layered, robot):
        m, d = layered.master, self.clearing_distance
        lo = m.world_to_map(robot[0] - d, robot[1] - d)
        hi = m.world_to_map(robot[0] + d, robot[1] + d)
        if lo is None or hi is None:
            return []
        out = []
        for layer in slow_clearing_layers(layered):
            layer.set_window_cost((lo[0], lo[1], hi[0] + 1, hi[1] + 1), FREE_SPACE)
            out.append(layer.name)
        layered.force_full_update = True
        return out

    def tick(self):
        """Lift the limit once the robot is limited_distance from where it began; returns
        what to log ('' when nothing happened)."""
        if not self.limit_set or self.global_costmap is None:
            return ""
        g = self.global_costmap.get_robot_pose()
        if g is None:
            return ""
        if self.limit_pose is None:
            self.limit_pose = (g[0], g[1])
            return ""
        if math.hypot(g[0] - self.limit_pose[0], g[1] - self.limit_pose[1]) < self.limited_distance:
            return ""
        if self.old:
            self.planner_params.set(self.namespace, dict(self.old))
        self.limit_set = False
        return "Moved far enough, removing speed limit."


def footprint_free(footprint, costmap, pose, x, y, th, limit=None):
    """The footprint at every pose (arrays x, y [m], th [rad]) of a motion from pose
    (x, y, yaw) keeps its clearance from the lethal and unknown cells (DWA's
    footprint_clearance: axis circles, refined by the grid circles and the corners near
    obstacles): >= 0, or from a pose already inside footprint_padding, down to
    clearance.ClearancePolicy.recovery. Held to >= 0 there, a robot that DWA's escape mode had left a
    centimetre from a wall could neither back up nor turn at all. limit: the lowest
    clearance allowed, as a function of the start pose's clearance (default:
    ClearancePolicy.recovery with the footprint's padding)."""
    dist = obstacle_distance(costmap)
    if dist is None:
        return True
    covers, corners = footprint_checks(footprint)
    # One pass over the start pose (first) and the motion's poses.
    clear = footprint_clearance(dist, costmap, np.append(float(pose[0]), x), np.append(float(pose[1]), y),
                                np.append(float(pose[2]), th), covers, corners)
    lowest = limit(float(clear[0])) if limit is not None else ClearancePolicy(footprint.padding).recovery(float(clear[0]))
    return bool((clear[1:] >= lowest).all())


def pose_clearance(footprint, costmap, pose):
    """DWA's footprint_clearance [m] of one pose (x, y, yaw); inf with no blocked cell."""
    dist = obstacle_distance(costmap)
    if dist is None:
        return math.inf
    covers, corners = footprint_checks(footprint)
    return float(footprint_clearance(dist, costmap, np.array([float(pose[0])]), np.array([float(pose[1])]),
                                     np.array([float(pose[2])]), covers, corners)[0])


class RotateRecovery:
    """rotate_recovery: turn a full circle in place, checking the footprint ahead.

    Parameters (rotate_recovery / base_local_planner names): sim_granularity [rad]
    (footprint check spacing along the turn; the wiki's and rotate_recovery.cpp's unit),
    frequency [Hz], acc_lim_th [rad/s^2], max_rotational_vel [rad/s],
    min_in_place_rotational_vel [rad/s], yaw_goal_tolerance [rad]; footprint: Footprint.
    """

    def __init__(self, footprint, sim_granularity=0.017, frequency=20.0, acc_lim_th=3.2,
                 max_rotational_vel=1.0, min_in_place_rotational_vel=0.4,
                 yaw_goal_tolerance=0.10, check_ahead=math.pi / 2.0):
        # the real node loops forever on a step of 0; ours refuses it at start
        _check_positive(sim_granularity=sim_granularity, frequency=frequency)
        self.footprint = footprint
        self.sim_granularity = sim_granularity
        self.frequency = frequency
        self.acc_lim_th = acc_lim_th
        self.max_rotational_vel = max_rotational_vel
        self.min_in_place_rotational_vel = min_in_place_rotational_vel
        self.tolerance = yaw_goal_tolerance
        self.check_ahead = check_ahead  # [rad] of turn checked for collisions each step
        self.turned = 0.0
        self.prev_yaw = None

    def start(self, pose, trail=()):
        """Begin a full turn from pose (x, y, yaw)."""
        self.turned = 0.0
        self.prev_yaw = pose[2]

    def step(self, pose, velocity, costmap):
        """Command for this period; done after a full turn, ok False when blocked."""
        if self.prev_yaw is None:
            self.start(pose)
        d = (pose[2] - self.prev_yaw + math.pi) % (2.0 * math.pi) - math.pi
        self.turned += abs(d)
        self.prev_yaw = pose[2]
        left = FULL_TURN - self.turned
        if left <= self.tolerance:
            return RecoveryStep(done=True)
        if not self._free(pose, min(left, self.check_ahead), costmap):
            return RecoveryStep(done=True, ok=False,
                                reason="rotate recovery stopped: turning would hit an obstacle")
        vel = math.sqrt(2.0 * self.acc_lim_th * left)
        vel = min(max(vel, self.min_in_place_rotational_vel), self.max_rotational_vel)
        return RecoveryStep(cmd=(0.0, 0.0, vel))

    def _free(self, pose, angle, costmap):
        """The footprint stays free of lethal/unknown cells over the next angle [rad] of turn
        (checked every sim_granularity [rad], with DWA's footprint_clearance: axis circles,
        refined by the grid circles and the corners near obstacles)."""
        step = self.sim_granularity
        n = max(1, int(math.ceil(angle / step)))
        sign = 1.0 if angle >= 0 else -1.0
        ths = pose[2] + sign * abs(angle) * np.arange(1, n + 1) / n
        return footprint_free(self.footprint, costmap, pose, np.full(n, float(pose[0])), np.full(n, float(pose[1])),
                              ths)


class BackUpRecovery:
    """Back up straight for backup_dist [m] at up to backup_speed [m/s], over ground the
    robot has driven: its centre stays within trail_tolerance [m] of its own recent
    positions (the trail move_base gives start()), and the footprint is checked over the
    next check_ahead [m] behind it every step; it stops where it would hit. After
    Navigation2's BackUp behaviour (backup_dist, backup_speed, time_allowance), which checks
    the costmap only: the laser looks forward, the cells behind a robot are as old as when
    it passed them, and behind a robot that never drove there they are simply unknown
    (free, without track_unknown_space). In a test ring the robot had never seen the wall
    behind it and backed into it.

    Why at all: DWA scores constant-velocity arcs, so it cannot plan a three-point turn. A
    robot that drove nose first between furniture, with its plan behind it, turned left and
    right in place for minutes on willow-full: each in-place turn was blocked a few tenths
    of a radian on, and rotate_recovery found that turning would hit. 0.3 m back along the
    way it came, DWA turned round and drove off (test_dwa, on the recorded costmap).

    frequency [Hz] is the rate step() is called at (for time_allowance); acc_lim_x
    [m/s^2] bounds the speed so that the robot can stop at backup_dist.
    """

    def __init__(self, footprint, backup_dist=0.3, backup_speed=0.1, time_allowance=10.0,
                 frequency=20.0, acc_lim_x=2.5, check_ahead=0.05, sim_granularity=0.01, trail_tolerance=0.1):
        _check_positive(backup_dist=backup_dist, backup_speed=backup_speed, time_allowance=time_allowance,
                        frequency=frequency, acc_lim_x=acc_lim_x, check_ahead=check_ahead,
                        sim_granularity=sim_granularity, trail_tolerance=trail_tolerance)
        self.trail_tolerance = float(trail_tolerance)
        self.footprint = footprint
        self.backup_dist = float(backup_dist)
        self.backup_speed = float(backup_speed)
        self.time_allowance = float(time_allowance)
        self.frequency = float(frequency)
        self.acc_lim_x = float(acc_lim_x)
        self.check_ahead = float(check_ahead)
        self.sim_granularity = float(sim_granularity)
        self.start_pose = None
        self.steps = 0
        self.limit = 0.0

    def start(self, pose, trail=()):
        """Begin backing up from pose (x, y, yaw); trail: the (x, y) [m] the robot's centre
        has recently been at, in the costmap's frame (its last few metres)."""
        self.start_pose = tuple(pose)
        self.steps = 0
        self.limit = retrace_distance(pose, trail, self.backup_dist, self.trail_tolerance, self.sim_granularity)

    def travelled(self, pose):
        """[m] from where it started."""
        return math.hypot(pose[0] - self.start_pose[0], pose[1] - self.start_pose[1])

    def step(self, pose, velocity, costmap):
        """Command for this period; done once backup_dist back, where backing on would hit
        (ok unless it could not move at all) or after time_allowance (not ok)."""
        if self.start_pose is None:
            self.start(pose)
        self.steps += 1
        done_m = self.travelled(pose)
        if self.limit < 0.02:
            return RecoveryStep(done=True, ok=False, reason="back up stopped: the robot has not driven over the "
                                "ground behind it (the laser does not see there)")
        left = self.limit - done_m
        if left <= 0.01:
            return RecoveryStep(done=True, reason=f"backed up {done_m:.2f} m" + (
                "" if self.limit >= self.backup_dist - 0.01 else ": as far as the robot has come that way"))
        if self.steps / self.frequency > self.time_allowance:
            return RecoveryStep(done=True, ok=False, reason=f"backed up only {done_m:.2f} m of "
                                f"{self.backup_dist:.2f} m in {self.time_allowance:.0f} s")
        if not self._free(pose, min(left, self.check_ahead), costmap):
            if done_m < 0.02:
                return RecoveryStep(done=True, ok=False, reason="back up stopped: backing up would hit an obstacle")
            return RecoveryStep(done=True, reason=f"backed up {done_m:.2f} m: backing up further would hit an obstacle")
        speed = min(self.backup_speed, math.sqrt(2.0 * self.acc_lim_x * left))
        return RecoveryStep(cmd=(-speed, 0.0, 0.0))

    def _free(self, pose, dist, costmap):
        """The footprint stays free of lethal/unknown cells over the next dist [m] straight
        back (every sim_granularity, DWA's footprint_clearance)."""
        n = max(1, int(math.ceil(dist / self.sim_granularity)))
        back = dist * np.arange(1, n + 1) / n
        return footprint_free(self.footprint, costmap, pose, pose[0] - back * math.cos(pose[2]),
                              pose[1] - back * math.sin(pose[2]), np.full(n, float(pose[2])))


# The moves of turn_around's search: (direction of travel, direction of turn); each goes
# step [m] and/or turns turn [rad].
TURN_MOVES = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))
MOVE_SUBSTEPS = 5          # footprint checks per move
FINE_LATTICE = 0.6         # turn_around's second search: moves this many times as long


def move_poses(pose, moves, step, turn):
    """The MOVE_SUBSTEPS poses along each move (v_sign, w_sign) of moves (K, 2) from pose
    (x, y, yaw), going step [m] and turning turn [rad] (arcs: the heading turns as it
    goes, each sub-step driven at its middle heading): (xs, ys, yaws), each (K, MOVE_SUBSTEPS)."""
    x, y, th = pose
    moves = np.asarray(moves, dtype=np.float64).reshape(-1, 2)
    frac = np.arange(1, MOVE_SUBSTEPS + 1) / MOVE_SUBSTEPS
    a = th + moves[:, 1:2] * turn * frac[None, :]
    mid = th + moves[:, 1:2] * turn * (frac[None, :] - 0.5 / MOVE_SUBSTEPS)
    d = moves[:, 0:1] * step / MOVE_SUBSTEPS
    return x + np.cumsum(d * np.cos(mid), axis=1), y + np.cumsum(d * np.sin(mid), axis=1), a


def manoeuvre_limit(c0, padding, keep):
    """The lowest clearance [m] turn_around's moves may reach from a start clearance c0 [m]:
    the padded footprint may go into footprint_padding but keep keep [m] of it, and never
    lower than where the robot already is or 0 (an unpadded footprint has no margin)."""
    return min(c0, 0.0, -padding + keep) if padding > keep else min(c0, 0.0)


def plan_manoeuvre(footprint, costmap, pose, step=0.05, turn=0.1, reach=0.6, goal_gain=0.02,
                   min_distance=0.25, keep=0.005, max_expansions=10000):
    """A sequence of moves out of a pocket: [(v_sign, w_sign), ...] or None.

    Uniform-cost search over poses (x, y, yaw) on a lattice of step [m] and turn [rad]
    moves (forward, backward, on the spot, and arcs of both), each checked at
    MOVE_SUBSTEPS poses with DWA's footprint_clearance, down to manoeuvre_limit (the
    padding but keep [m] of it). Goal: a pose min_distance [m] or more from the start
    whose clearance is goal_gain [m] above the start's (and at least goal_gain), from
    which DWA has room to turn and drive on. Moves stay within reach [m] of the start.
    Cost: distance driven, the turns at the footprint's circumscribed radius, and a
    penalty of one step per change of direction (fewer shunts).
    """
    dist = obstacle_distance(costmap)
    if dist is None:
        return []
    covers, corners = footprint_checks(footprint)

    def clearance(x, y, th):
        return footprint_clearance(dist, costmap, x, y, th, covers, corners)

    x0, y0, th0 = (float(v) for v in pose)
    c0 = float(clearance(np.array([x0]), np.array([y0]), np.array([th0]))[0])
    limit = manoeuvre_limit(c0, footprint.padding, keep)
    target = max(c0, 0.0) + goal_gain
    r = footprint.circumscribed_radius

    def key(x, y, th):
        return (round(x / (0.4 * step)), round(y / (0.4 * step)), round(wrap_angle(th) / (0.5 * turn)))

    parent = {key(x0, y0, th0): None}
    heap = [(0.0, 0, (x0, y0, th0), 0)]
    count = 0
    while heap and count < max_expansions:
        cost, _, (x, y, th), last_v = heapq.heappop(heap)
        count += 1
        xs, ys, a = move_poses((x, y, th), TURN_MOVES, step, turn)   # the moves from here
        clear = clearance(xs, ys, a)
        ok = (clear >= limit).all(axis=1) & (np.hypot(xs[:, -1] - x0, ys[:, -1] - y0) <= reach)
        for i in np.flatnonzero(ok):
            v, w = TURN_MOVES[i]
            end = (float(xs[i, -1]), float(ys[i, -1]), float(a[i, -1]))
            k = key(*end)
            if k in parent:
                continue
            parent[k] = (key(x, y, th), (v, w))
            if clear[i, -1] >= target and math.hypot(end[0] - x0, end[1] - y0) >= min_distance:
                seq = [(v, w)]
                k = key(x, y, th)
                while parent[k] is not None:
                    k, mv = parent[k]
                    seq.append(mv)
                return seq[::-1]
            c = cost + abs(v) * step + abs(w) * turn * r + (step if v != 0 and last_v != 0 and v != last_v else 0.0)
            heapq.heappush(heap, (c, len(parent), end, v if v != 0 else last_v))
    return None


def search_manoeuvre(footprint, costmap, pose, step=0.05, turn=0.1, keep=0.005, **search):
    """plan_manoeuvre on the lattice of step and turn, then on one FINE_LATTICE times as
    fine: a way out on one lattice may fall between the other's poses (of the seven
    recorded wedges of a willow-full run each lattice missed one or two). Both keep keep
    [m] of footprint_padding; when neither finds a way, both again with none of it kept
    (down to the unpadded footprint's edge): a robot in a channel barely wider than
    itself, whose clearance wobbles by a centimetre as the footprint crosses cells, found
    no way back out that kept 5 mm (willow-full seed 1, 28% explored, stuck). Returns
    (moves, (step, turn, keep) they were found with); moves None when no search finds a way."""
    for kept in (keep, 0.0) if keep > 0.0 else (keep,):
        for scale in (1.0, FINE_LATTICE):
            used = (step * scale, turn * scale, kept)
            moves = plan_manoeuvre(footprint, costmap, pose, step=used[0], turn=used[1], keep=kept, **search)
            if moves is not None:
                return moves, used
    return None, used


class TurnAroundRecovery:
    """Turn round in a pocket: plan_manoeuvre's moves, driven one by one.

    Why: DWA scores constant-velocity arcs a cycle at a time, so it cannot plan a
    three-point turn, and back_up only drives straight back. On willow-full a robot that
    had followed its plan into a dead-end pocket between a wall and a table (the plan then
    moved behind it) stood there: no arc forward or back stayed clear, rotate_recovery
    found that turning would hit, and explore gave its goals up one by one until "the
    robot is stuck". The search found a way out with five shunts, going into the padding
    by 1.5 cm at most. The moves keep keep [m] of footprint_padding when some way out
    does, and spend it only when none does (search_manoeuvre).

    Each move is driven at speed [m/s] (arcs and straight moves) or at
    min_in_place_rotational_vel [rad/s] (turns on the spot) until odometry shows it done;
    before each command the rest of the move is checked on the live costmap, and when it
    would go below the limit its search kept to, the robot stops and the moves are searched again (up to
    replans times). Done once the moves are driven (ok), or when no way out is found or
    time_allowance [s] runs out (not ok). frequency [Hz]: the rate step() is called at. A
    robot with room [m] of clearance or more is not in a pocket: done at once (the
    recoveries also run when no global plan is found).
    """

    def __init__(self, footprint, speed=0.1, min_in_place_rotational_vel=0.3, step=0.05, turn=0.1,
                 reach=0.6, goal_gain=0.02, min_distance=0.25, keep=0.005, time_allowance=20.0,
                 frequency=20.0, replans=3, max_expansions=10000, room=0.05):
        _check_positive(speed=speed, min_in_place_rotational_vel=min_in_place_rotational_vel, step=step,
                        turn=turn, reach=reach, goal_gain=goal_gain, min_distance=min_distance,
                        time_allowance=time_allowance, frequency=frequency, max_expansions=max_expansions,
                        room=room)
        if not isinstance(keep, (int, float)) or not 0.0 <= keep or not math.isfinite(keep):
            raise ValueError(f"keep: expected a number >= 0, got {keep!r}")
        if not isinstance(replans, int) or replans < 0:
            raise ValueError(f"replans: expected an integer >= 0, got {replans!r}")
        self.footprint = footprint
        self.speed, self.rot_vel = float(speed), float(min_in_place_rotational_vel)
        self.search = dict(step=float(step), turn=float(turn), reach=float(reach), goal_gain=float(goal_gain),
                           min_distance=float(min_distance), keep=float(keep), max_expansions=int(max_expansions))
        self.time_allowance, self.frequency, self.replans = float(time_allowance), float(frequency), replans
        self.room = float(room)
        self.moves = None

    def start(self, pose, trail=()):
        """Begin: the moves are searched at the first step (it has the costmap)."""
        self.moves, self.move_start, self.steps, self.searches, self.start_pose = None, None, 0, 0, tuple(pose)

    def _search(self, pose, costmap):
        self.searches += 1
        found, (step, turn, self.kept) = search_manoeuvre(self.footprint, costmap, pose, **self.search)
        self.lattice = (step, turn)
        self.moves = list(found) if found is not None else None
        self.move_start = tuple(pose)
        return found is not None

    def _rest_free(self, pose, costmap, v, w, left):
        """The rest of the current move (left: its fraction not yet driven) stays above the limit."""
        step, turn = self.lattice
        xs, ys, a = move_poses(pose, [(v, w)], step * max(left, 0.0), turn * max(left, 0.0))
        return footprint_free(self.footprint, costmap, pose, xs[0], ys[0], a[0],
                              limit=lambda c0: manoeuvre_limit(c0, self.footprint.padding, self.kept) - 1e-3)

    def step(self, pose, velocity, costmap):
        """Command for this period (see the class docstring)."""
        if self.moves is None and self.searches == 0:
            if pose_clearance(self.footprint, costmap, pose) >= self.room:
                return RecoveryStep(done=True, reason="turn around: the robot has room already")
            if not self._search(pose, costmap):
                return RecoveryStep(done=True, ok=False, reason="turn around: no way out found within "
                                    f"{self.search['reach']:.1f} m")
            if not self.moves:
                return RecoveryStep(done=True, reason="turn around: the robot has room already")
        self.steps += 1
        if self.steps / self.frequency > self.time_allowance:
            return RecoveryStep(done=True, ok=False, reason=f"turn around: not done in {self.time_allowance:.0f} s")
        while self.moves:
            v, w = self.moves[0]
            sx, sy, sth = self.move_start
            done_d = math.hypot(pose[0] - sx, pose[1] - sy) / self.lattice[0] if v else 1.0
            done_a = abs(wrap_angle(pose[2] - sth)) / self.lattice[1] if w else 1.0
            if min(done_d, done_a) >= 0.95:
                self.moves.pop(0)
                self.move_start = tuple(pose)
                continue
            left = 1.0 - min(done_d, done_a)
            if not self._rest_free(pose, costmap, v, w, left):
                if self.searches > self.replans or not self._search(pose, costmap):
                    return RecoveryStep(done=True, ok=False, reason="turn around: the way out closed")
                continue
            if v:
                return RecoveryStep(cmd=(v * self.speed, 0.0, w * self.speed * self.lattice[1] / self.lattice[0]))
            return RecoveryStep(cmd=(0.0, 0.0, w * self.rot_vel))
        return RecoveryStep(done=True, reason=f"turn around: done in {self.searches} search(es), "
                            f"{math.hypot(pose[0] - self.start_pose[0], pose[1] - self.start_pose[1]):.2f} m from "
                            "where it started")


def retrace_distance(pose, trail, max_dist, tolerance, step=0.01):
    """How far [m] (up to max_dist) the robot at pose (x, y, yaw) can back up straight over
    its trail [(x, y), ...]: its centre stays within tolerance [m] of a trail point, and no
    farther from pose than the trail goes (a robot that has not moved may not back up by
    the tolerance into ground it never saw)."""
    pts = np.asarray(trail, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return 0.0
    extent = float(np.hypot(pts[:, 0] - pose[0], pts[:, 1] - pose[1]).max())
    reach = min(max_dist, extent)
    if reach <= 0.0:
        return 0.0
    s = np.arange(1, int(math.ceil(reach / step)) + 1) * step
    s[-1] = reach
    cx = pose[0] - s * math.cos(pose[2])
    cy = pose[1] - s * math.sin(pose[2])
    near = np.hypot(cx[:, None] - pts[None, :, 0], cy[:, None] - pts[None, :, 1]).min(axis=1) <= tolerance
    if near.all():
        return float(reach)
    first_off = int(np.argmin(near))
    return float(s[first_off - 1]) if first_off > 0 else 0.0


def _check_positive(**values):
    for k, v in values.items():
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v) or v <= 0:
            raise ValueError(f"{k}: expected a positive number, got {v!r}")


CLEAR_TYPE = "clear_costmap_recovery/ClearCostmapRecovery"
ROTATE_TYPE = "rotate_recovery/RotateRecovery"
BACKUP_TYPE = "my_summit_path_planning/BackUpRecovery"
TURN_AROUND_TYPE = "my_summit_path_planning/TurnAroundRecovery"
SLOW_TYPE = "move_slow_and_clear/MoveSlowAndClear"
RECOVERY_TYPES = (CLEAR_TYPE, ROTATE_TYPE, BACKUP_TYPE, TURN_AROUND_TYPE, SLOW_TYPE)
