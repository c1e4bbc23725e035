"""Live tuning of move_base with dynamic_reconfigure, under the real servers' names.

- ``~DWAPlannerROS`` (cfg/DWAPlanner.cfg, dwa_local_planner's names and ranges): the DWA
  configuration is swapped between two control cycles; ``restore_defaults`` brings back
  the configuration move_base started with.
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
    """~DWAPlannerROS: swaps the DWA configuration (node.p.dwa and the running planner's)
    under node.lock."""

    name = "DWAPlannerROS"

    def __init__(self, node):
        super().__init__()
        self.node = node
        self.startup = node.dwa.config

    def current(self):
        return dataclasses.asdict(self.node.dwa.config)

    def apply(self, changes):
        new = dwa_config(dict(dataclasses.asdict(self.node.dwa.config), **changes))   # ParamError if unusable
        with self.node.lock:
            self.node.p.dwa = new          # move_base makes a fresh DWAPlanner from it per goal
            self.node.dwa.config = new
            osc = self.node.dwa.oscillation
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
    servers = [StrictServer(DWAPlannerConfig, DWAReconfigure(node), namespace="~DWAPlannerROS")]
    for cm in (node.gcm, node.lcm):
        for layer in cm.layered.layers:
            if isinstance(layer, InflationLayer):
                servers.append(StrictServer(InflationPluginConfig, InflationReconfigure(cm, layer),
                                            namespace=f"~{cm.name}/{layer.name}"))
    return servers
