"""Live tuning of move_base with dynamic_reconfigure, under the real servers' names.

- ``~DWAPlannerROS`` (cfg/DWAPlanner.cfg, dwa_local_planner's names and ranges), when
  the local planner is dwa_local_planner/DWAPlannerROS: the DWA configuration is swapped
  between two control cycles (the running planner's and the next goals');
  ``restore_defaults`` brings back the configuration move_base started with.
- ``~global_costmap/<inflation layer>`` and ``~local_costmap/<inflation layer>``
  (cfg/InflationPlugin.cfg, costmap_2d's): the layer's parameters change and the whole
  costmap is re-inflated on its next update.

The servers are summit_nav_common.ros.reconfigure.StrictServer: a value outside the .cfg's range
is refused (logged with the valid range), not clamped. A combination the planner cannot
run with (e.g. min_vel_x above max_vel_x) is refused the same way. The first callback
(at start) only reports the parameters loaded from the YAML files.
"""
import dataclasses

import rospy

from my_summit_path_planning.layers import InflationLayer
from my_summit_path_planning.params import ParamError, dwa_config
from summit_nav_common.ros.reconfigure import StrictServer

DWA_TYPE = "dwa_local_planner/DWAPlannerROS"


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
    """~DWAPlannerROS: swaps the DWA configuration of the running local planner
    (node.core.local_planner) and of the ones move_base makes for the next goals
    (node.plugins.local_params), under node.lock."""

    name = "DWAPlannerROS"

    def __init__(self, node):
        super().__init__()
        self.node = node
        self.startup = dwa_config(node.plugins.local_params)

    def current(self):
        return dataclasses.asdict(dwa_config(self.node.plugins.local_params))

    def apply(self, changes):
        new = dwa_config(dict(self.current(), **changes))   # ParamError if unusable
        with self.node.lock:
            self.node.plugins.local_params = dataclasses.asdict(new)   # each goal's fresh planner
            planner = self.node.core.local_planner
            if planner is not None:
                planner.config = new
                osc = planner.oscillation
                osc.reset_dist, osc.reset_angle = new.oscillation_reset_dist, new.oscillation_reset_angle

    def defaults_changes(self):
        cur, start = self.current(), dataclasses.asdict(self.startup)
        return {k: v for k, v in start.items() if cur[k] != v}


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


def start_servers(node):
    """The dynamic_reconfigure servers of a move_base node (kept alive by the caller)."""
    from my_summit_path_planning.cfg import DWAPlannerConfig, InflationPluginConfig
    servers = []
    if node.plugins.local_type == DWA_TYPE:
        servers.append(StrictServer(DWAPlannerConfig, DWAReconfigure(node), namespace="~DWAPlannerROS"))
    for cm in (node.gcm, node.lcm):
        for layer in cm.layered.layers:
            if isinstance(layer, InflationLayer):
                servers.append(StrictServer(InflationPluginConfig, InflationReconfigure(cm, layer),
                                            namespace=f"~{cm.name}/{layer.name}"))
    return servers
