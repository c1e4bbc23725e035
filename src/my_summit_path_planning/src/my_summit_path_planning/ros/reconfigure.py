"""Live tuning of move_base with dynamic_reconfigure, under the real servers' names.

The planners' servers are chosen by the planner's type string (SERVERS), as the
registry chooses the planners; each is served at ~<namespace> (nav_core.namespace_of):

- ``~DWAPlannerROS`` (cfg/DWAPlanner.cfg, dwa_local_planner's names and ranges), when
  the local planner is dwa_local_planner/DWAPlannerROS;
- ``~TrajectoryPlannerROS`` (cfg/BaseLocalPlanner.cfg, base_local_planner's), when it is
  base_local_planner/TrajectoryPlannerROS;
  for both, the configuration is swapped between two control cycles (the running
  planner's and the next goals'); ``restore_defaults`` brings back the configuration
  move_base started with (as the real nodes: their first configuration);
- ``~GlobalPlanner`` (cfg/GlobalPlanner.cfg, global_planner's: costs, orientation mode
  and window, publish_potential), when the global planner is global_planner/GlobalPlanner:
  the next plan (the planner thread's and ~make_plan's) uses the new values.
- ``~global_costmap/<inflation layer>`` and ``~local_costmap/<inflation layer>``
  (cfg/InflationPlugin.cfg, costmap_2d's): the layer's parameters change and the whole
  costmap is re-inflated on its next update.

The callbacks reach move_base through PlannerSlot, a narrow interface (planner_slots
builds the two of a move_base): the parameters the next planners of a kind are built
from, and update(params, configure), which swaps them and reconfigures the planners
running now under move_base's lock. The inflation callbacks reach a costmap through its
lock and layered costmap only.

The servers are summit_nav_common.ros.reconfigure.StrictServer: a value outside the .cfg's range
is refused (logged with the valid range), not clamped. A value or combination the planner cannot
run with (e.g. min_vel_x above max_vel_x for DWA, sim_time 0 or an unparsable y_vels for
the Trajectory Rollout planner) is refused the same way, the planner's ParamError text
logged. The first callback (at start) only reports the parameters in use (the YAML
files' or the planner's defaults).
"""
import dataclasses
import importlib
import queue
import threading
from dataclasses import dataclass
from typing import Callable

import rospy
from dynamic_reconfigure.msg import Config, DoubleParameter
from dynamic_reconfigure.srv import Reconfigure
from summit_nav_common.ros.reconfigure import StrictServer

from ..layers import InflationLayer
from ..params import ParamError, dwa_config


@dataclass
class PlannerSlot:
    """One planner kind of move_base as its reconfigure server reaches it.

    type: the planner's type string; name: its namespace; params(): the namespace the
    next planners of this kind are built from; update(params, configure): under
    move_base's lock, make params the next planners' namespace and call configure(planner)
    on each planner running now; controller_frequency [Hz]: move_base's."""

    type: str
    name: str
    params: Callable
    update: Callable
    controller_frequency: float = 20.0


def planner_slots(plugins, lock, running_global, running_local):
    """(global slot, local slot) of a move_base: plugins (MoveBasePlugins: global_params,
    local_params, the types and names, ctx.controller_frequency); lock: the lock its control
    loop and planner thread hold; running_global() / running_local(): the planners using
    the configuration now (None entries skipped)."""

    def updater(attr, running):
        def update(params, configure):
            with lock:
                setattr(plugins, attr, params)
                for planner in running():
                    if planner is not None:
                        configure(planner)
        return update

    rate = plugins.ctx.controller_frequency
    return (PlannerSlot(plugins.global_type, plugins.global_name, lambda: plugins.global_params,
                        updater("global_params", running_global), rate),
            PlannerSlot(plugins.local_type, plugins.local_name, lambda: plugins.local_params,
                        updater("local_params", running_local), rate))


class _Callback:
    """Shared first-call handling: the server's initial config reports what is in use."""

    def __init__(self):
        self.started = False

    def __call__(self, config, _level):
        current = self.current()
        names = [k for k in config if k in current]
        if not self.started:
            self.started = True
            config.update({k: current[k] for k in names})
            return config
        changes = {k: type(current[k])(config[k]) for k in names if config[k] != current[k]}
        if config.get("restore_defaults"):
            changes = self.defaults_changes()
            config["restore_defaults"] = False
        if changes:
            try:
                self.apply(changes)
            except ParamError as e:
                rospy.logwarn(f"move_base: reconfigure refused: {e}")
                config.update({k: current[k] for k in changes if k in config})
                return config
            rospy.loginfo(f"move_base: {self.name} reconfigured: "
                          + ", ".join(f"{k} = {v}" for k, v in changes.items()))
        config.update({k: v for k, v in self.current().items() if k in config})
        return config

    def defaults_changes(self):
        return {}


class DWAReconfigure(_Callback):
    """~DWAPlannerROS: swaps the DWA configuration of the running local planner and of the
    ones move_base makes for the next goals (slot: the local PlannerSlot)."""

    name = "DWAPlannerROS"

    def __init__(self, slot):
        super().__init__()
        self.slot = slot
        self.startup = dwa_config(slot.params())

    def current(self):
        return dataclasses.asdict(dwa_config(self.slot.params()))

    def apply(self, changes):
        new = dwa_config(dict(self.current(), **changes))   # ParamError if unusable

        def configure(planner):
            planner.config = new
            osc = planner.oscillation
            osc.reset_dist, osc.reset_angle = new.oscillation_reset_dist, new.oscillation_reset_angle
        self.slot.update(dataclasses.asdict(new), configure)   # and each goal's fresh planner

    def defaults_changes(self):
        cur, start = self.current(), dataclasses.asdict(self.startup)
        return {k: v for k, v in start.items() if cur[k] != v}


class TrajectoryReconfigure(_Callback):
    """~TrajectoryPlannerROS: swaps the TrajectoryPlannerConfig of the running local planner
    and of the next goals' (slot: the local PlannerSlot). y_vels is served as the real
    .cfg's comma-separated string; angular_sim_granularity as the step in use
    (sim_granularity when unset)."""

    name = "TrajectoryPlannerROS"

    def __init__(self, slot):
        super().__init__()
        self.slot = slot
        self.startup = self.current()

    def _config(self, params):
        from ..trajectory_planner import trajectory_planner_config   # only when chosen
        cfg, _notes = trajectory_planner_config(params, self.slot.name, self.slot.controller_frequency)
        return cfg

    def current(self):
        cfg = self._config(self.slot.params())
        out = dataclasses.asdict(cfg)
        out["angular_sim_granularity"] = cfg.angular_granularity
        out["y_vels"] = ",".join(f"{v:g}" for v in cfg.y_vels)
        return out

    def apply(self, changes):
        # the configuration in use under the current names (deprecated ones resolved), then the changes
        params = {k: v for k, v in dataclasses.asdict(self._config(self.slot.params())).items()
                  if v is not None}
        new = self._config(dict(params, **changes))   # ParamError if unusable
        self.slot.update({k: v for k, v in dataclasses.asdict(new).items() if v is not None},
                         lambda planner: setattr(planner, "config", new))

    def defaults_changes(self):
        cur = self.current()
        return {k: v for k, v in self.startup.items() if cur[k] != v}


class GlobalPlannerReconfigure(_Callback):
    """~GlobalPlanner: the configuration of the planners running (the planner thread's and
    ~make_plan's) and of later ones (slot: the global PlannerSlot); a plan already being
    made finishes with the values it started with."""

    name = "GlobalPlanner"

    def __init__(self, slot):
        super().__init__()
        self.slot = slot

    def _config(self, params):
        from ..global_planner import GlobalPlanner   # only when chosen
        return GlobalPlanner.from_params(params, self.slot.name).config   # ParamError if unusable

    def current(self):
        return dataclasses.asdict(self._config(self.slot.params()))

    def apply(self, changes):
        params = dict(self.slot.params(), **changes)
        new = self._config(params)
        self.slot.update(params, lambda planner: setattr(planner, "config", dataclasses.replace(new)))


class InflationReconfigure(_Callback):
    """~<costmap>/<inflation layer>: the layer's four parameters, then a full update."""

    FIELDS = ("enabled", "inflation_radius", "cost_scaling_factor", "inflate_unknown")

    def __init__(self, costmap_ros, layer):
        super().__init__()
        self.cm, self.layer = costmap_ros, layer
        self.name = f"{costmap_ros.name}/{layer.name}"

    def current(self):
        return {k: getattr(self.layer, k) for k in self.FIELDS}

    def apply(self, changes):
        with self.cm.lock:
            for k, v in changes.items():
                setattr(self.layer, k, v)
            self.cm.layered.force_full_update = True


# planner type -> (the generated my_summit_path_planning.cfg.<name>Config, its callback class)
SERVERS = {
    "dwa_local_planner/DWAPlannerROS": ("DWAPlanner", DWAReconfigure),
    "base_local_planner/TrajectoryPlannerROS": ("BaseLocalPlanner", TrajectoryReconfigure),
    "global_planner/GlobalPlanner": ("GlobalPlanner", GlobalPlannerReconfigure),
}


def config_type(cfg_name):
    """The generated dynamic_reconfigure module of cfg/<cfg_name>.cfg."""
    return importlib.import_module(f"my_summit_path_planning.cfg.{cfg_name}Config")


def start_servers(slots, costmaps):
    """The dynamic_reconfigure servers of a move_base (kept alive by the caller): one per
    PlannerSlot whose type has one, one per inflation layer of the costmaps (each with
    name, lock and layered)."""
    servers = []
    for slot in slots:
        if slot.type in SERVERS:
            cfg_name, callback = SERVERS[slot.type]
            servers.append(StrictServer(config_type(cfg_name), callback(slot), namespace=f"~{slot.name}"))
    InflationPluginConfig = config_type("InflationPlugin")
    for cm in costmaps:
        for layer in cm.layered.layers:
            if isinstance(layer, InflationLayer):
                servers.append(StrictServer(InflationPluginConfig, InflationReconfigure(cm, layer),
                                            namespace=f"~{cm.name}/{layer.name}"))
    return servers


SERVICE_WAIT = 2.0   # [s] how long a planner's set_parameters service is waited for


class PlannerParams:
    """The planners' parameters as move_slow_and_clear reaches them (nav_core.PluginContext
    .planner_params): get() reads ~<namespace>/<name> from the parameter server; set()
    sends the values to ~<namespace>/set_parameters, the namespace's dynamic_reconfigure
    service, as the real recovery does. The calls are made in order by a worker thread:
    the control loop that runs the recovery holds the lock the planners' reconfigure
    callbacks take, so it must not wait for them."""

    def __init__(self):
        self.requests = queue.Queue()
        threading.Thread(target=self._run, daemon=True, name="planner_params").start()

    def get(self, namespace, name):
        try:
            value = rospy.get_param(f"~{namespace}/{name}")
        except KeyError:
            return None
        return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None

    def set(self, namespace, values):
        self.requests.put((namespace, dict(values)))

    def _run(self):
        while not rospy.is_shutdown():
            try:
                namespace, values = self.requests.get(timeout=0.5)
            except queue.Empty:
                continue
            service = rospy.resolve_name(f"~{namespace}/set_parameters")
            text = ", ".join(f"{k} = {v:g}" for k, v in values.items())
            try:
                rospy.wait_for_service(service, SERVICE_WAIT)
                rospy.ServiceProxy(service, Reconfigure)(
                    Config(doubles=[DoubleParameter(name=k, value=float(v)) for k, v in values.items()]))
                rospy.loginfo(f"move_base: recovery setting {text} ({service})")
            except (rospy.ROSException, rospy.ServiceException) as e:
                rospy.logerr(f"move_base: could not set {text} through {service}: {e}")
