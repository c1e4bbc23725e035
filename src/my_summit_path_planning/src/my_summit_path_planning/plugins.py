"""move_base's plugins by type string: the registrations, and the recovery list's loading.

Reference: move_base.cpp (loadRecoveryBehaviors, loadDefaultRecoveryBehaviors) and the
plugin descriptions of navfn, global_planner, dwa_local_planner, base_local_planner,
clear_costmap_recovery and rotate_recovery (wiki.ros.org). The interfaces and the
Registry are in nav_core.

Registered here:
  base_global_planner  navfn/NavfnROS (navfn.NavFn), global_planner/GlobalPlanner
                       (global_planner.GlobalPlanner), carrot_planner/CarrotPlanner
                       (carrot_planner.CarrotPlanner)
  base_local_planner   dwa_local_planner/DWAPlannerROS (dwa.DWAPlanner),
                       base_local_planner/TrajectoryPlannerROS (trajectory_planner.TrajectoryPlanner)
  recovery_behaviors   clear_costmap_recovery/ClearCostmapRecovery,
                       rotate_recovery/RotateRecovery, move_slow_and_clear/MoveSlowAndClear,
                       and ours:
                       my_summit_path_planning/BackUpRecovery, .../TurnAroundRecovery
A registration is one line: ``REGISTRY.register(type, factory(params, ctx, where))``.
The planners move_base's default configuration does not pick (global_planner,
carrot_planner, base_local_planner) are imported by their factory, when chosen (their
modules and kernels are then loaded only by a move_base that uses them; the kernels are C,
summit_nav_common/csrc, so no planner loads numba).
"""
import inspect

from . import recovery
from .dwa import DWAPlanner
from .nav_core import PluginContext, PluginError, Registry, namespace_of
from .navfn import NavFn
from .param_reader import ANY, BOOL, FLOAT, STR, STR_LIST, WARNING, Field, Note, Schema
from .params import dwa_config, navfn_config

GLOBAL_PLANNERS = Registry("base_global_planner")
LOCAL_PLANNERS = Registry("base_local_planner")
RECOVERY_BEHAVIORS = Registry("recovery_behaviors")


# -- local planners' limits, which rotate_recovery and back_up move within ---------------------
def dwa_limits(params):
    """DWAPlannerROS's limits (its defaults where unset, old names accepted)."""
    cfg = dwa_config(params)
    return dict(acc_lim_th=cfg.acc_lim_theta, max_rotational_vel=cfg.max_vel_theta,
                min_in_place_rotational_vel=cfg.min_vel_theta, yaw_goal_tolerance=cfg.yaw_goal_tolerance,
                acc_lim_x=cfg.acc_lim_x)


TRAJECTORY_LIMITS = Schema([   # TrajectoryPlannerROS's limits, by its names, the deprecated ones after
    Field("acc_lim_theta", FLOAT, 3.2, old=("acc_lim_th",)),                        # [rad/s^2]
    Field("max_vel_theta", FLOAT, 1.0, old=("max_rotational_vel",)),                # [rad/s]
    Field("min_in_place_vel_theta", FLOAT, 0.4, old=("min_in_place_rotational_vel",)),  # [rad/s]
    Field("yaw_goal_tolerance", FLOAT, 0.05),                                        # [rad]
    Field("acc_lim_x", FLOAT, 2.5),                                                  # [m/s^2]
])


def trajectory_planner_limits(params):
    """TrajectoryPlannerROS's limits, read as rotate_recovery reads them (its names, the
    deprecated ones after, base_local_planner's defaults); the planner itself reports its
    parameters' notes."""
    r = TRAJECTORY_LIMITS.read({k: v for k, v in (params or {}).items() if k in TRAJECTORY_LIMITS.known},
                               "TrajectoryPlannerROS", error=PluginError)
    return dict(acc_lim_th=r["acc_lim_theta"], max_rotational_vel=r["max_vel_theta"],
                min_in_place_rotational_vel=r["min_in_place_vel_theta"], yaw_goal_tolerance=r["yaw_goal_tolerance"],
                acc_lim_x=r["acc_lim_x"])


# -- planners ---------------------------------------------------------------------------------
def _navfn(params, ctx, where):
    """NavFn from its namespace; .notes: the names it does not read."""
    notes = []
    planner = NavFn(navfn_config(params, where, notes, note_where=f"~{where}"))
    planner.notes = notes
    return planner


def _global_planner(params, ctx, where):
    from .global_planner import GlobalPlanner   # imported only when chosen
    return GlobalPlanner.from_params(params, where, f"~{where}")


def _carrot_planner(params, ctx, where):
    from .carrot_planner import CarrotPlanner
    return CarrotPlanner.from_params(params, ctx.footprint, where, f"~{where}")


GLOBAL_PLANNERS.register("navfn/NavfnROS", _navfn)
GLOBAL_PLANNERS.register("global_planner/GlobalPlanner", _global_planner)
GLOBAL_PLANNERS.register("carrot_planner/CarrotPlanner", _carrot_planner)

def _dwa_planner(params, ctx, where):
    """DWAPlanner from its namespace; .notes: its parameters' notes and what
    dwa_local_planner does that it does not (move_base logs them once)."""
    notes = []
    cfg = dwa_config(params, where, notes, note_where=f"~{where}")
    planner = DWAPlanner(cfg, ctx.footprint)
    planner.notes = notes + [Note(
        WARNING, "max_scaling_factor", f"~{where}: footprint speed scaling is not implemented: scaling_speed {cfg.scaling_speed} and "
        f"max_scaling_factor {cfg.max_scaling_factor} are ignored (dwa_local_planner checks the footprint "
        f"scaled up to x{1 + cfg.max_scaling_factor:g} at max_vel_trans); the footprint is checked at its size")]
    if not cfg.use_dwa:
        planner.notes.append(Note(WARNING, "use_dwa", f"~{where}/use_dwa false is ignored: this planner always "
                                                      f"samples the dynamic window"))
    return planner


LOCAL_PLANNERS.register("dwa_local_planner/DWAPlannerROS", _dwa_planner, limits=dwa_limits)
def _trajectory_planner(params, ctx, where):
    from .trajectory_planner import TrajectoryPlanner   # imported only when chosen
    return TrajectoryPlanner.from_params(params, ctx.footprint, where, controller_frequency=ctx.controller_frequency,
                                         note_where=f"~{where}")


LOCAL_PLANNERS.register("base_local_planner/TrajectoryPlannerROS", _trajectory_planner,
                        limits=trajectory_planner_limits)


# -- recovery behaviours ------------------------------------------------------------------------
NUMBER = dict(kind=FLOAT, what="a number")   # the recoveries' words for a float
CLEAR_SCHEMA = Schema([                       # clear_costmap_recovery's parameters
    Field("reset_distance", default=3.0, **NUMBER),                                  # [m]
    Field("layer_names", STR_LIST, factory=lambda: list(recovery.DEFAULT_LAYER_NAMES)),
    Field("force_clear_all", BOOL, False),
    Field("invert_area_to_clear", BOOL, False),
    Field("force_updating", BOOL, False),
    # the real node's warning for another value, and its fallback
    Field("affected_maps", ANY, "both", choices=recovery.AFFECTED_MAPS, fallback=True,
          note="~{where}/affected_maps: Wrong value for affected_maps parameter: '{value}'; valid values are "
               "'local', 'global' or 'both'; defaulting to 'both'"),
])
SLOW_SCHEMA = Schema([                        # move_slow_and_clear's parameters
    Field("clearing_distance", default=0.5, lo=0.0, **NUMBER),                       # [m]
    Field("limited_trans_speed", default=0.25, lo=0.0, **NUMBER),                    # [m/s]
    Field("limited_rot_speed", default=0.45, lo=0.0, **NUMBER),                      # [rad/s]
    Field("limited_distance", default=0.3, lo=0.0, **NUMBER),                        # [m]
    Field("max_trans_param_name", STR, "max_trans_vel"),
    Field("max_rot_param_name", STR, "max_rot_vel"),
    Field("planner_namespace", STR, "DWAPlannerROS"),
])


def _clear_costmap(params, ctx, where):
    r = CLEAR_SCHEMA.read(params, where, f"~{where}", error=PluginError)
    beh = recovery.ClearCostmapRecovery(ctx.global_costmap, ctx.local_costmap, r["reset_distance"],
                                        tuple(r["layer_names"]), r["force_clear_all"], r["invert_area_to_clear"],
                                        r["affected_maps"], r["force_updating"])
    beh.notes = r.notes + [f"~{where}: {n}" for n in beh.clearing_notes()]
    return beh


def _rotate_kwargs(ctx):
    lim = ctx.local_limits
    return dict(frequency=ctx.controller_frequency,
                **{k: lim[k] for k in ("acc_lim_th", "max_rotational_vel", "min_in_place_rotational_vel",
                                       "yaw_goal_tolerance") if k in lim})


def _move_slow_and_clear(params, ctx, where):
    """move_slow_and_clear from ~<name> (its names and defaults); .notes: the names it
    does not read and the costmaps where it would clear nothing."""
    r = SLOW_SCHEMA.read(params, where, f"~{where}", error=PluginError)
    beh = recovery.MoveSlowAndClear(ctx.global_costmap, ctx.local_costmap, ctx.planner_params, **r.values)
    beh.notes = r.notes + beh.clearing_notes()
    return beh


RECOVERY_BEHAVIORS.register(recovery.CLEAR_TYPE, _clear_costmap)
RECOVERY_BEHAVIORS.register(recovery.SLOW_TYPE, _move_slow_and_clear)


def _behaviour(cls, defaults):
    """A factory for a recovery class taking the footprint and keyword parameters: its
    namespace's names the class takes (a schema of its signature; the class checks the
    values), over defaults(ctx); every other name is noted and left unread, as the real
    recovery behaviours leave what they do not read."""
    schema = Schema([Field(n, ANY, p.default) for n, p in inspect.signature(cls).parameters.items()
                     if n != "footprint"])

    def factory(params, ctx, where):
        r = schema.read(params, where, f"~{where}", error=PluginError)
        beh = cls(ctx.footprint, **{**defaults(ctx), **{k: r[k] for k in r.given}})
        beh.notes = r.notes
        return beh
    return factory


RECOVERY_BEHAVIORS.register(recovery.ROTATE_TYPE, _behaviour(recovery.RotateRecovery, _rotate_kwargs))
RECOVERY_BEHAVIORS.register(recovery.BACKUP_TYPE, _behaviour(recovery.BackUpRecovery, lambda ctx: {
    "frequency": ctx.controller_frequency, **{k: v for k, v in ctx.local_limits.items() if k == "acc_lim_x"}}))
RECOVERY_BEHAVIORS.register(recovery.TURN_AROUND_TYPE, _behaviour(recovery.TurnAroundRecovery, lambda ctx: {
    "frequency": ctx.controller_frequency,
    **{k: v for k, v in ctx.local_limits.items() if k == "min_in_place_rotational_vel"}}))


def recovery_sequence(spec, namespaces, ctx):
    """move_base's recovery_behaviors list [{name, type}, ...] -> [(name, behaviour), ...].

    namespaces: {name: {param: value}}, each behaviour's own namespace (~<name>/...);
    clear_costmap_recovery reads reset_distance (3.0 m), layer_names ([obstacles]),
    invert_area_to_clear, affected_maps, force_updating and force_clear_all (false;
    ours); rotate_recovery, back_up and turn_around start from the local planner's limits
    and move_base's controller_frequency (ctx), overridden by their namespace. ValueError naming the entry when the list is malformed, a name
    repeats, a type is unknown or a parameter is bad (move_base then logs it and uses its
    default sequence).
    """
    if not isinstance(spec, (list, tuple)) or not spec:
        raise ValueError(f"recovery_behaviors: expected a non-empty list of {{name, type}}, got {spec!r}")
    seq, names = [], set()
    for i, entry in enumerate(spec):
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str) \
                or not isinstance(entry.get("type"), str) or not entry["name"]:
            raise ValueError(f"recovery_behaviors[{i}]: expected {{name: ..., type: ...}}, got {entry!r}")
        name, kind = entry["name"], entry["type"]
        if name in names:
            raise ValueError(f"recovery_behaviors[{i}]: the name {name!r} is used twice")
        names.add(name)
        try:
            beh = RECOVERY_BEHAVIORS.create(kind, (namespaces or {}).get(name), ctx, name)
        except (TypeError, ValueError) as e:
            raise ValueError(f"recovery_behaviors[{i}] ({name}): {e}") from None
        seq.append((name, beh))
    return seq


def default_recovery_sequence(ctx, conservative_reset_dist=3.0, clearing_rotation_allowed=True,
                              namespaces=None, circumscribed_radius=0.46):
    """move_base's default recoveries in order: [(name, behaviour), ...].

    conservative_reset (reset_distance = conservative_reset_dist [m]), rotate_recovery,
    aggressive_reset (reset_distance = 4 x circumscribed_radius [m], move_base's
    ~local_costmap/circumscribed_radius parameter, not the footprint's), rotate_recovery; the
    rotations are left out when clearing_rotation_allowed is false. namespaces: the
    behaviours' own namespaces (~conservative_reset/layer_names, ...); move_base sets
    their reset_distance itself.
    """
    namespaces = namespaces or {}
    spec = [{"name": "conservative_reset", "type": recovery.CLEAR_TYPE}]
    if clearing_rotation_allowed:
        spec.append({"name": "rotate_recovery", "type": recovery.ROTATE_TYPE})
    spec.append({"name": "aggressive_reset", "type": recovery.CLEAR_TYPE})
    ns = {"conservative_reset": {**(namespaces.get("conservative_reset") or {}),
                                 "reset_distance": float(conservative_reset_dist)},
          "aggressive_reset": {**(namespaces.get("aggressive_reset") or {}), "reset_distance":
                               recovery.AGGRESSIVE_RADIUS_FACTOR * float(circumscribed_radius)},
          "rotate_recovery": namespaces.get("rotate_recovery") or {}}
    seq = recovery_sequence(spec, ns, ctx)
    if clearing_rotation_allowed:
        # the same rotate_recovery runs twice, as in move_base
        seq.append(seq[1])
    return seq


def planner_context(footprint, local_type, local_params, global_costmap=None, local_costmap=None,
                    controller_frequency=20.0, planner_params=None):
    """The PluginContext move_base builds its plugins with (the local planner's limits
    read from its namespace)."""
    plugin = LOCAL_PLANNERS.resolve(local_type)
    limits = plugin.limits(local_params or {}) if plugin.limits is not None else {}
    return PluginContext(global_costmap=global_costmap, local_costmap=local_costmap, footprint=footprint,
                         controller_frequency=controller_frequency, local_limits=limits,
                         planner_params=planner_params)


def plugin_notes(planner):
    """What a plugin says about its parameters (nav_core: ``notes``, param_reader Notes:
    names it does not read, old names, clamped values, the real node's warnings); a
    plugin built without parameters has none."""
    return list(getattr(planner, "notes", ()))


class MoveBasePlugins:
    """The plugins of one move_base configuration (params.MoveBaseParams), loaded by type.

    Builds a global and a local planner at once so that a bad type or parameter fails at
    start (PluginError / ParamError naming it); make_global_planner() and
    make_local_planner() build further ones (move_base gives each goal a fresh local
    planner; the planner thread and ~make_plan each have their own global planner).
    recoveries: [(name, behaviour), ...]; recovery_error: why the recovery_behaviors list
    was refused ('' when it was used or not given), the defaults then standing in, as in
    move_base. warn(text): where deprecation warnings go.
    """

    def __init__(self, p, global_costmap=None, local_costmap=None, footprint=None, warn=None,
                 planner_params=None):
        mb = p.move_base
        self.global_type = GLOBAL_PLANNERS.resolve(mb.base_global_planner, warn).type
        self.local_type = LOCAL_PLANNERS.resolve(mb.base_local_planner, warn).type
        self.global_name = namespace_of(self.global_type)
        self.local_name = namespace_of(self.local_type)
        self.global_params = p.namespace(self.global_name)
        self.local_params = p.namespace(self.local_name)
        if footprint is None and local_costmap is not None:
            footprint = local_costmap.layered.footprint
        self.ctx = planner_context(footprint, self.local_type, self.local_params, global_costmap, local_costmap,
                                   mb.controller_frequency, planner_params)
        self.global_planner = self.make_global_planner()
        self.local_planner = self.make_local_planner()
        # What the planners say about their parameters, for the node to log once.
        self.notes = plugin_notes(self.global_planner) + plugin_notes(self.local_planner)
        self.recovery_error = ""
        self.recoveries = None
        if mb.recovery_behaviors is not None:
            try:
                self.recoveries = recovery_sequence(mb.recovery_behaviors, p.namespaces, self.ctx)
            except ValueError as e:
                self.recovery_error = str(e)
        if self.recoveries is None:
            self.recoveries = default_recovery_sequence(self.ctx, mb.conservative_reset_dist,
                                                        mb.clearing_rotation_allowed, p.namespaces,
                                                        p.local_costmap.circumscribed_radius)
        seen = set()
        for name, beh in self.recoveries:
            if id(beh) not in seen:
                seen.add(id(beh))
                self.notes += plugin_notes(beh)

    def make_global_planner(self):
        return GLOBAL_PLANNERS.create(self.global_type, self.global_params, self.ctx, self.global_name)

    def make_local_planner(self):
        return LOCAL_PLANNERS.create(self.local_type, self.local_params, self.ctx, self.local_name)

    def goal_tolerance(self):
        """(allow_unknown, default_tolerance [m]) of the global planner's namespace, with
        navfn's and global_planner's common defaults (true, 0.0)."""
        allow = self.global_params.get("allow_unknown", True)
        tol = self.global_params.get("default_tolerance", 0.0)
        return bool(allow), float(tol)
