"""nav_core's plugin shapes and a pluginlib-like registry of them, by the real type strings.

Reference: ROS 1 navigation nav_core (base_global_planner.h: makePlan;
base_local_planner.h: setPlan / computeVelocityCommands / isGoalReached;
recovery_behavior.h: runBehavior) and move_base.cpp, which loads its global planner,
local planner and recovery behaviours by type string ("navfn/NavfnROS",
"dwa_local_planner/DWAPlannerROS", "rotate_recovery/RotateRecovery", ...) and hands each
the parameters of its own namespace: ~<class name> for a planner (the type's part after
the '/'), ~<name> for a recovery behaviour.

Each kind has one small shape (the Protocols below). A Registry maps type strings to
factories ``factory(params, ctx, where) -> plugin``: params is the dict of the plugin's
own namespace ({} when it is missing: every parameter takes its default, as in the real
move_base), ctx a PluginContext of collaborators (costmaps, footprint), where the
namespace's name for error messages. A factory reads its namespace with a
param_reader.Schema and leaves what it has to say about it (names it does not read, old
names, clamped values) in the plugin's ``notes``, which move_base logs once; a plugin
without ``notes`` has nothing to say. The registrations themselves are in
my_summit_path_planning.plugins. An unknown type is a PluginError naming the known ones,
as pluginlib's; a type whose module is not in this build says so.
"""
from dataclasses import dataclass, field
from typing import Callable, Dict, Optional, Protocol

from .params import ParamError


class PluginError(ParamError):
    """A plugin type that is unknown or cannot be built, or a plugin lacking its interface."""


# -- the three shapes ---------------------------------------------------------------------
class GlobalPlanner(Protocol):
    """nav_core::BaseGlobalPlanner."""

    def make_plan(self, costmap, start, goal, tolerance=None):
        """Plan on costmap (a Costmap2D, read only) from start to goal, each (x, y, yaw)
        [m, m, rad] (nav_core's poses; a planner may use only x and y); tolerance [m]
        overrides the planner's default_tolerance. Returns a PlanResult-like
        object: path (N, 2) [m] or None, ok, reason (why there is no plan)."""


class LocalPlanner(Protocol):
    """nav_core::BaseLocalPlanner."""

    def set_plan(self, plan, goal_yaw):
        """A global plan: (N, 2) points [m] in the local costmap's frame; goal heading [rad]."""

    def reframe_plan(self, delta):
        """The local frame moved against the global one: re-express the plan held (as pruned)
        and the goal heading by the rigid transform delta (x [m], y [m], yaw [rad]), a point
        p going to R(yaw) p + (x, y). Nothing else changes (the goal latch, the pruning)."""

    def compute_velocity_commands(self, pose, velocity, costmap):
        """One control cycle: pose (x, y, yaw) in the local frame, body velocity (vx, vy, vth)
        from odometry, the local Costmap2D. Returns a result with cmd (vx [m/s], vy [m/s],
        vth [rad/s]), ok (False: no valid command, reason says why) and optionally
        trajectory ((T, 3) poses of the chosen command, for ~local_plan)."""

    def is_goal_reached(self):
        """True once the goal pose is reached (xy and yaw tolerances)."""

    def set_control_latency(self, seconds):
        """The measured time between control cycles [s], for braking on a late loop."""


class RecoveryBehavior(Protocol):
    """nav_core::RecoveryBehavior, run a control period at a time instead of blocking."""

    def start(self, pose, trail=()):
        """Begin at pose (x, y, yaw) in the local frame; trail: the (x, y) [m] the robot's
        centre has recently been at in that frame (its last few metres)."""

    def step(self, pose, velocity, costmap):
        """Command for this period: a RecoveryStep (cmd, done, ok, reason)."""


INTERFACES = {
    "base_global_planner": ("make_plan",),
    "base_local_planner": ("set_plan", "compute_velocity_commands", "is_goal_reached", "set_control_latency"),
    "recovery_behaviors": ("start", "step"),
}


@dataclass
class PluginContext:
    """What a plugin may be built with besides its parameters.

    global_costmap, local_costmap: costmap handles (``layered``: a LayeredCostmap,
    ``lock``, ``get_robot_pose()`` -> (x, y, yaw) or None, optionally ``update()``: one
    update at the robot's pose now), or None; footprint: the local
    costmap's Footprint (controller and recoveries); controller_frequency [Hz];
    local_limits: the local planner's rotation and acceleration limits for the recoveries
    (acc_lim_th [rad/s^2], max_rotational_vel and min_in_place_rotational_vel [rad/s],
    yaw_goal_tolerance [rad], acc_lim_x [m/s^2]); planner_params: the node's access to
    the planners' parameters (get(namespace, name) -> value or None, and
    set(namespace, {name: value}) through the namespace's dynamic_reconfigure server), or
    None.
    """

    global_costmap: object = None
    local_costmap: object = None
    footprint: object = None
    controller_frequency: float = 20.0
    local_limits: dict = field(default_factory=dict)
    planner_params: object = None


@dataclass
class Plugin:
    """One registered type: its factory and, for a local planner, how to read its limits
    (params dict -> PluginContext.local_limits)."""

    type: str
    factory: Callable
    limits: Optional[Callable] = None


class Registry:
    """Type string -> factory, for one kind (its parameter name: 'base_global_planner', ...)."""

    def __init__(self, kind):
        if kind not in INTERFACES:
            raise ValueError(f"unknown plugin kind {kind!r}; known: {sorted(INTERFACES)}")
        self.kind = kind
        self.plugins: Dict[str, Plugin] = {}

    def register(self, type_name, factory, limits=None):
        """Make type_name ("package/Class") build with factory(params, ctx, where)."""
        if type_name.count("/") != 1:
            raise ValueError(f"{self.kind}: type {type_name!r} is not of the form 'package/Class'")
        self.plugins[type_name] = Plugin(type_name, factory, limits)

    def known(self):
        return sorted(self.plugins)

    def resolve(self, type_name, warn=None):
        """The registered Plugin for type_name; a bare class name ("NavfnROS") resolves to the
        one type with that class name, with a warning through warn(text), as move_base's
        deprecated form. PluginError naming the known types otherwise."""
        if not isinstance(type_name, str):
            raise PluginError(f"{self.kind}: expected a type string such as {self.known()[0]!r}, "
                              f"got {type_name!r}")
        if type_name in self.plugins:
            return self.plugins[type_name]
        bare = [t for t in self.plugins if t.split("/")[1] == type_name]
        if len(bare) == 1:
            if warn is not None:
                warn(f"{self.kind} specifications should include the package name: {type_name!r} is "
                     f"deprecated, use {bare[0]!r}")
            return self.plugins[bare[0]]
        raise PluginError(f"{self.kind}: unknown type {type_name!r}; known types are: {', '.join(self.known())}")

    def create(self, type_name, params, ctx, where, warn=None):
        """Build the plugin of type_name from its namespace's params (None or missing: {})."""
        plugin = self.resolve(type_name, warn)
        if params is None:
            params = {}
        if not isinstance(params, dict):
            raise PluginError(f"{where}: expected a namespace of parameters, got {params!r}")
        obj = plugin.factory(dict(params), ctx, where)
        missing = [m for m in INTERFACES[self.kind] if not callable(getattr(obj, m, None))]
        if missing:
            raise PluginError(f"{self.kind} {plugin.type}: {type(obj).__name__} lacks {', '.join(missing)} "
                              f"(the {self.kind} interface: {', '.join(INTERFACES[self.kind])})")
        return obj


def namespace_of(type_name):
    """The parameter namespace move_base gives a planner: the type's class part
    ("navfn/NavfnROS" -> "NavfnROS")."""
    return type_name.split("/")[-1]
