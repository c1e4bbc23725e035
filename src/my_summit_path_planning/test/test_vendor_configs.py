"""The robot vendors' own move_base configurations build our move_base as they build the real one.

The workspace's data/vendor holds husky_navigation's, jackal_navigation's and turtlebot3_navigation's
launch files and YAML, unchanged (README there). Each launch file is read by roslaunch's
own XML loader, as `roslaunch` reads it (its <rosparam load ns=...>, <param>, <arg>), with
`$(find PKG)` pointed at the copy; the move_base node's parameters then build our
move_base's parameters, both costmaps and the plugins, as the node does at start. The
real move_base starts with each of them; ours refused all three until names it does not
read were left unread (husky: recovery_behaviour_enabled; jackal: meter_scoring in its
costmaps) and a sample count below 1 raised to 1 as dynamic_reconfigure does
(turtlebot3: DWAPlannerROS vy_samples 0).
"""
import os
import re

import pytest
import roslaunch.config
import roslaunch.xmlloader

from my_summit_path_planning.dwa import DWAPlanner
from my_summit_path_planning.navfn import NavFn
from my_summit_path_planning.params import build_costmap, move_base_params
from my_summit_path_planning.plugins import MoveBasePlugins
from my_summit_path_planning.trajectory_planner import TrajectoryPlanner

VENDOR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "data", "vendor")  # the workspace's


def launch_params(tmp_path, package, launch, node="move_base", argv=()):
    """The parameters roslaunch gives node from VENDOR/package/launch, as a nested dict."""
    text = open(os.path.join(VENDOR, package, launch)).read()
    text = re.sub(r"\$\(find (\w+)\)", lambda m: os.path.join(VENDOR, m.group(1)), text)
    path = tmp_path / os.path.basename(launch)
    path.write_text(text)
    cfg = roslaunch.config.ROSLaunchConfig()
    roslaunch.xmlloader.XmlLoader().load(str(path), cfg, verbose=False, argv=list(argv))
    prefix = f"/{node}/"
    tree = {}
    for name, p in cfg.params.items():
        if name.startswith(prefix):
            *ns, key = name[len(prefix):].split("/")
            d = tree
            for k in ns:
                d = d.setdefault(k, {})
            d[key] = p.value
    assert tree, f"{launch} sets no parameter of {node}"
    return tree


class Built:
    """What the move_base node builds at start from a parameter tree."""

    def __init__(self, tree):
        self.warnings = []
        self.p = move_base_params(tree, "/move_base")
        self.warnings += self.p.notes
        self.costmaps = {name: build_costmap(getattr(self.p, name), name, log=self.warnings.append)
                         for name in ("global_costmap", "local_costmap")}
        holders = {k: type("Holder", (), {"layered": v})() for k, v in self.costmaps.items()}
        self.plugins = MoveBasePlugins(self.p, holders["global_costmap"], holders["local_costmap"],
                                       warn=self.warnings.append)
        self.warnings += self.plugins.notes

    def layers(self, name):
        return [(type(l).__name__, l.name) for l in self.costmaps[name].layers]

    def said(self, text):
        return any(text in w for w in self.warnings)


def test_husky_navigation_dwa(tmp_path):
    b = Built(launch_params(tmp_path, "husky_navigation", "launch/move_base.launch"))
    assert b.layers("global_costmap") == [("StaticLayer", "static"), ("InflationLayer", "inflation")]
    assert b.layers("local_costmap") == [("ObstacleLayer", "obstacles_laser"), ("InflationLayer", "inflation")]
    local = b.costmaps["local_costmap"]
    assert local.rolling_window and (local.master.size_x, local.master.size_y) == (200, 200)  # 10 m at 0.05
    src = local.layer("obstacles_laser").sources["laser"]
    assert src["topic"] == "front/scan" and src["inf_is_valid"] is True
    assert local.layer("inflation").inflation_radius == 1.0
    assert local.footprint.inscribed_radius == pytest.approx(0.34)          # 0.66 m wide, padding 0.01
    assert isinstance(b.plugins.global_planner, NavFn)
    assert b.plugins.global_planner.config.default_tolerance == 0.1
    dwa = b.plugins.local_planner
    assert isinstance(dwa, DWAPlanner)
    c = dwa.config
    assert (c.max_vel_x, c.max_vel_trans, c.min_vel_trans, c.xy_goal_tolerance) == (0.5, 0.5, 0.1, 0.2)
    # max_vel_rot / min_vel_rot / acc_lim_th are no DWAPlannerROS names: the defaults stand
    assert (c.max_vel_theta, c.min_vel_theta, c.acc_lim_theta) == (1.0, 0.4, 3.2)
    assert b.p.move_base.controller_frequency == 5.0
    assert b.said("'recovery_behaviour_enabled' is not a parameter this node reads; ignored "
                  "(did you mean 'recovery_behavior_enabled'?)")
    assert b.said("DWAPlannerROS: 'max_vel_rot' is not a parameter this node reads")


def test_husky_navigation_trajectory_planner(tmp_path):
    tree = launch_params(tmp_path, "husky_navigation", "launch/move_base.launch",
                         argv=["base_local_planner:=base_local_planner/TrajectoryPlannerROS"])
    b = Built(tree)
    tpr = b.plugins.local_planner
    assert isinstance(tpr, TrajectoryPlanner)
    c = tpr.config
    assert (c.path_distance_bias, c.goal_distance_bias, c.occdist_scale) == (0.75, 1.0, 0.1)   # pdist/gdist_scale
    assert c.meter_scoring and c.dwa and not c.holonomic_robot
    assert (c.max_vel_x, c.sim_time, c.vx_samples, c.vtheta_samples, c.escape_vel) == (1.0, 2.0, 6, 20, -0.1)
    assert b.said("Parameter pdist_scale is deprecated. Please use the name path_distance_bias instead.")


def test_jackal_navigation(tmp_path):
    b = Built(launch_params(tmp_path, "jackal_navigation", "launch/include/move_base.launch"))
    assert b.layers("global_costmap") == [("StaticLayer", "static_layer"), ("ObstacleLayer", "obstacles_layer"),
                                          ("InflationLayer", "inflater_layer")]
    assert b.layers("local_costmap") == [("ObstacleLayer", "obstacles_layer"), ("InflationLayer", "inflater_layer")]
    glob = b.costmaps["global_costmap"]
    assert (glob.master.size_x, glob.master.origin_x) == (800, -20.0)     # 40 m at 0.05, until the map comes
    src = glob.layer("obstacles_layer").sources["scan"]
    assert (src["min_obstacle_height"], src["max_obstacle_height"], src["sensor_frame"]) == (-2.0, 2.0, "front_laser")
    assert glob.footprint.inscribed_radius == pytest.approx(0.265)         # 0.33 m wide, padding 0.1
    assert isinstance(b.plugins.local_planner, TrajectoryPlanner)
    c = b.plugins.local_planner.config
    assert (c.acc_lim_x, c.acc_lim_theta, c.max_vel_x, c.escape_vel, c.controller_frequency) == \
        (10.0, 20.0, 0.5, -0.5, 20.0)
    assert b.said("global_costmap: 'meter_scoring' is not a parameter this node reads; ignored")
    assert b.p.move_base.oscillation_timeout == 0.0 and b.p.move_base.planner_frequency == 20.0


@pytest.mark.parametrize("model,max_vel_theta", [("burger", 2.75), ("waffle", 1.82), ("waffle_pi", 1.82)])
def test_turtlebot3_navigation(tmp_path, monkeypatch, model, max_vel_theta):
    monkeypatch.setenv("TURTLEBOT3_MODEL", model)   # move_base.launch's model argument defaults to it
    b = Built(launch_params(tmp_path, "turtlebot3_navigation", "launch/move_base.launch"))
    assert b.said('Parameter "plugins" not provided, loading pre-Hydro parameters')
    assert b.layers("global_costmap") == [("StaticLayer", "static_layer"), ("ObstacleLayer", "obstacle_layer"),
                                          ("InflationLayer", "inflation_layer")]
    assert b.layers("local_costmap") == [("ObstacleLayer", "obstacle_layer"), ("InflationLayer", "inflation_layer")]
    local = b.costmaps["local_costmap"]
    assert (local.master.size_x, local.master.size_y) == (60, 60)           # 3 m at 0.05
    assert local.layer("obstacle_layer").sources["scan"]["sensor_frame"] == "base_scan"
    assert b.p.local_costmap.robot_base_frame == "base_footprint"
    # the outline is off-centre (base_footprint is on the wheel axle): its front edge is
    # nearest, plus costmap_2d's default footprint_padding, 0.01 m
    front = {"burger": 0.041}.get(model, 0.077)
    assert local.footprint.inscribed_radius == pytest.approx(front + 0.01)
    c = b.plugins.local_planner.config
    assert isinstance(b.plugins.local_planner, DWAPlanner)
    assert (c.vx_samples, c.vy_samples, c.vth_samples, c.max_vel_theta) == (20, 1, 40, max_vel_theta)
    assert c.min_vel_x < 0                                                   # it may back up
    assert b.said("DWAPlannerROS: 'vy_samples' 0 raised to 1")
    assert b.p.move_base.planner_frequency == 5.0
