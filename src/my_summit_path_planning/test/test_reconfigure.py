"""move_base's dynamic_reconfigure callbacks (ros/reconfigure.py) on fake move_base nodes,
reached through their PlannerSlots as the node's are.

The servers are the real StrictServer over the generated .cfg modules, with rospy's
parameter server, publishers and services replaced by dicts and stubs (no ROS master):

- ~TrajectoryPlannerROS: the YAML's values are reported at start (deprecated names
  resolved, a YAML list for y_vels accepted); a change reaches the running planner (its
  next command obeys the new max_vel_x) and the next goals' planners; a value outside the
  .cfg's range, or one the planner cannot run with (sim_time 0, y_vels not numbers), is
  refused with a message naming it; restore_defaults brings back the start.
- ~GlobalPlanner: cost_factor and orientation_mode change the next plan of both planners
  (the planner thread's and ~make_plan's); out-of-range values are refused.
- The servers are chosen by the planners' type strings; the .cfg files carry the real
  names, and GlobalPlanner.cfg's ranges and defaults are global_planner's.
"""
import math
import threading
from types import SimpleNamespace

import numpy as np
import numpy.testing as npt
import pytest
import rospy

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning import trajectory_planner as tp
from my_summit_path_planning.costmap import Costmap2D, Footprint
from my_summit_path_planning.global_planner import _RANGES, GlobalPlanner, GlobalPlannerConfig
from my_summit_path_planning.ros import reconfigure as rr
from summit_nav_common.ros.reconfigure import StrictServer

SUMMIT = [[0.36, 0.31], [-0.36, 0.31], [-0.36, -0.31], [0.36, -0.31]]
TPR = "base_local_planner/TrajectoryPlannerROS"
GP = "global_planner/GlobalPlanner"
# config/base_local_planner_params.yaml's values that matter here (Trajectory Rollout)
TPR_YAML = {"holonomic_robot": False, "acc_lim_x": 2.5, "acc_lim_theta": 5.0, "max_vel_x": 0.65,
            "min_vel_x": 0.1, "max_vel_theta": 3.0, "min_vel_theta": -3.0, "sim_time": 1.0,
            "sim_granularity": 0.025, "vx_samples": 3, "vtheta_samples": 20, "dwa": False}


class FakeRos:
    """rospy's parameter server, publishers, services and log, as dicts and lists."""

    def __init__(self, monkeypatch, params=None):
        self.params = dict(params or {})
        self.warnings, self.infos = [], []
        monkeypatch.setattr(rospy, "get_param", self._get)
        monkeypatch.setattr(rospy, "set_param", self.params.__setitem__)
        monkeypatch.setattr(rospy, "Publisher", lambda *a, **k: SimpleNamespace(publish=lambda msg: None))
        monkeypatch.setattr(rospy, "Service", lambda *a, **k: None)
        monkeypatch.setattr(rospy, "logwarn", self.warnings.append)
        monkeypatch.setattr(rospy, "loginfo", self.infos.append)

    def _get(self, name, *default):
        if name in self.params:
            return self.params[name]
        if default:
            return default[0]
        raise KeyError(name)


def _fake_node(local_type=TPR, local_params=None, global_type=GP, global_params=None):
    fp = Footprint.from_params(SUMMIT, padding=0.01)
    local_name, global_name = local_type.split("/")[1], global_type.split("/")[1]
    plugins = SimpleNamespace(local_type=local_type, local_name=local_name, local_params=dict(local_params or {}),
                              global_type=global_type, global_name=global_name,
                              global_params=dict(global_params or {}),
                              ctx=SimpleNamespace(controller_frequency=20.0, footprint=fp))
    node = SimpleNamespace(plugins=plugins, lock=threading.RLock(), core=SimpleNamespace(local_planner=None),
                           gcm=SimpleNamespace(layered=SimpleNamespace(layers=[])),
                           lcm=SimpleNamespace(layered=SimpleNamespace(layers=[])))
    if local_type == TPR:
        node.core.local_planner = _tpr(node)
    node.planner = node.service_planner = None
    if global_type == GP:
        node.planner = GlobalPlanner.from_params(plugins.global_params)
        node.service_planner = GlobalPlanner.from_params(plugins.global_params)
    # what the callbacks reach, as move_base builds it
    node.slots = rr.planner_slots(plugins, node.lock, lambda: (node.planner, node.service_planner),
                                  lambda: (node.core.local_planner,))
    return node


def _tpr(node):
    """A TrajectoryPlanner as move_base makes one for a goal (MoveBasePlugins.make_local_planner)."""
    pl = node.plugins
    return tp.TrajectoryPlanner.from_params(pl.local_params, pl.ctx.footprint, pl.local_name, 20.0)


def _server(node, kind):
    cfg_name, callback = rr.SERVERS[kind]
    slot = next(s for s in node.slots if s.type == kind)
    return StrictServer(rr.config_type(cfg_name), callback(slot), namespace=f"~{kind.split('/')[1]}")


def _corridor_cmd(planner):
    """The planner's command at rest at the start of a straight 3.4 m plan along a corridor."""
    m = Costmap2D(140, 140, 0.05, -3.5, -3.5)
    m.data[np.abs(np.arange(140) * 0.05 - 3.5 + 0.025) > 0.8, :] = cv.LETHAL_OBSTACLE
    planner.set_plan(np.column_stack([np.linspace(0.0, 3.4, 69), np.zeros(69)]), 0.0)
    r = planner.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert r.ok, r.reason
    return r.cmd


# -- ~TrajectoryPlannerROS ---------------------------------------------------------------------
def test_trajectory_server_reports_the_planner_in_use(monkeypatch):
    FakeRos(monkeypatch, {"~TrajectoryPlannerROS/max_vel_x": 0.65})
    node = _fake_node(local_params=TPR_YAML)
    srv = _server(node, TPR)
    c = srv.config
    assert c["max_vel_x"] == 0.65 and c["sim_time"] == 1.0 and c["vx_samples"] == 3 and not c["dwa"]
    assert c["holonomic_robot"] is False and c["min_vel_theta"] == -3.0
    # not in the YAML: the planner's defaults, not the .cfg's (sim_time 1.7, vx_samples 20, pi/2)
    assert c["escape_reset_theta"] == pytest.approx(math.pi / 4) and c["heading_scoring_timestep"] == 0.8
    assert c["angular_sim_granularity"] == 0.025          # unset: sim_granularity
    assert c["y_vels"] == "-0.3,-0.1,0.1,0.3"
    assert node.core.local_planner.config.max_vel_x == 0.65


def test_trajectory_change_reaches_the_running_and_the_next_planners(monkeypatch):
    ros = FakeRos(monkeypatch)
    node = _fake_node(local_params=TPR_YAML)
    running = node.core.local_planner
    assert _corridor_cmd(_tpr(node))[0] == pytest.approx(0.65)   # the fastest straight sample
    srv = _server(node, TPR)
    cfg = srv.update_configuration({"max_vel_x": 0.3, "y_vels": "-0.2, 0.2"})
    assert cfg["max_vel_x"] == 0.3 and cfg["y_vels"] == "-0.2,0.2"
    assert node.core.local_planner is running and running.config.max_vel_x == 0.3
    assert running.config.y_vels == (-0.2, 0.2)
    assert _corridor_cmd(running)[0] == pytest.approx(0.3)
    assert _corridor_cmd(_tpr(node))[0] == pytest.approx(0.3)     # the next goal's planner
    assert any("TrajectoryPlannerROS reconfigured:" in t and "max_vel_x = 0.3" in t for t in ros.infos), ros.infos
    assert ros.params["~TrajectoryPlannerROS/max_vel_x"] == 0.3


def test_trajectory_out_of_range_is_refused(monkeypatch):
    ros = FakeRos(monkeypatch)
    node = _fake_node(local_params=TPR_YAML)
    srv = _server(node, TPR)
    cfg = srv.update_configuration({"max_vel_x": 50.0, "min_vel_theta": 0.5, "vx_samples": 0})
    assert cfg["max_vel_x"] == 0.65 and cfg["min_vel_theta"] == -3.0 and cfg["vx_samples"] == 3
    assert node.core.local_planner.config.max_vel_x == 0.65
    text = "\n".join(ros.warnings)
    assert "max_vel_x = 50.0: valid range [0.0, 20.0]; keeping 0.65" in text
    assert "min_vel_theta = 0.5: valid range [-20.0, 0.0]" in text
    assert "vx_samples = 0: valid range [1, 300]" in text


@pytest.mark.parametrize("change, message", [
    ({"sim_time": 0.0}, "TrajectoryPlannerROS: 'sim_time' must be > 0, got 0.0 (TrajectoryPlannerROS/sim_time)"),
    ({"angular_sim_granularity": 0.0}, "TrajectoryPlannerROS: 'angular_sim_granularity' must be > 0"),
    ({"y_vels": "fast,slow"}, "TrajectoryPlannerROS: 'y_vels' must be a list of floats, got 'fast,slow'"),
])
def test_trajectory_unusable_values_are_refused(monkeypatch, change, message):
    """In the .cfg's range (or a string) but the planner cannot run with it: refused, nothing changes."""
    ros = FakeRos(monkeypatch)
    node = _fake_node(local_params=TPR_YAML)
    srv = _server(node, TPR)
    before = srv.config.copy()
    cfg = srv.update_configuration(dict(change, max_vel_x=0.3))
    assert any(message in t and "reconfigure refused" in t for t in ros.warnings), ros.warnings
    assert {k: cfg[k] for k in change} == {k: before[k] for k in change}
    assert cfg["max_vel_x"] == 0.65   # the whole change is refused
    assert node.core.local_planner.config == tp.trajectory_planner_config(TPR_YAML)[0]


def test_trajectory_restore_defaults_brings_back_the_start(monkeypatch):
    FakeRos(monkeypatch)
    node = _fake_node(local_params=TPR_YAML)
    start = node.core.local_planner.config
    srv = _server(node, TPR)
    srv.update_configuration({"max_vel_x": 0.3, "sim_time": 2.0, "dwa": True, "y_vels": "0.1"})
    assert node.core.local_planner.config.sim_time == 2.0
    cfg = srv.update_configuration({"restore_defaults": True})
    assert cfg["restore_defaults"] is False
    assert cfg["max_vel_x"] == 0.65 and cfg["sim_time"] == 1.0 and cfg["dwa"] is False
    assert cfg["y_vels"] == "-0.3,-0.1,0.1,0.3"
    got = node.core.local_planner.config
    assert (got.max_vel_x, got.sim_time, got.dwa, got.y_vels) == (0.65, 1.0, False, start.y_vels)
    assert _tpr(node).config.max_vel_x == 0.65


def test_trajectory_deprecated_names_and_a_yaml_list(monkeypatch):
    """navigation_stage's YAML: deprecated names (resolved once, kept through a change) and
    y_vels as a list (not taken by the server as its str parameter; the planner's is reported)."""
    params = {"pdist_scale": 0.9, "max_rotational_vel": 2.0, "y_vels": [-0.3, -0.1, 0.1, -0.3]}
    FakeRos(monkeypatch, {f"~TrajectoryPlannerROS/{k}": v for k, v in params.items()})
    node = _fake_node(local_params=params)
    srv = _server(node, TPR)
    c = srv.config
    assert (c["path_distance_bias"], c["max_vel_theta"], c["min_vel_theta"]) == (0.9, 2.0, -2.0)
    assert c["y_vels"] == "-0.3,-0.1,0.1,-0.3"
    cfg = srv.update_configuration({"occdist_scale": 0.02})
    got = node.core.local_planner.config
    assert (got.occdist_scale, got.path_distance_bias, got.max_vel_theta, got.min_vel_theta) == (0.02, 0.9, 2.0, -2.0)
    assert cfg["path_distance_bias"] == 0.9
    assert _tpr(node).config.path_distance_bias == 0.9


# -- ~GlobalPlanner -------------------------------------------------------------------------------
def _direct(planner, two_gaps):
    r = planner.make_plan(two_gaps.costmap(), (0.25, 1.05), (3.75, 1.05, 0.7))
    assert r.ok, r.reason
    return two_gaps.through_direct_gap(r), r


def test_global_change_reaches_the_next_plans(monkeypatch, two_gaps):
    ros = FakeRos(monkeypatch)
    node = _fake_node(global_params={"allow_unknown": False})
    srv = _server(node, GP)
    c = srv.config
    assert (c["lethal_cost"], c["neutral_cost"], c["cost_factor"], c["orientation_mode"]) == (253, 50, 3.0, 1)
    assert _direct(node.planner, two_gaps)[0] is False          # the dear gap: round by the free one
    cfg = srv.update_configuration({"cost_factor": 0.1, "orientation_mode": 4})   # Backward
    assert cfg["cost_factor"] == 0.1 and cfg["orientation_mode"] == 4
    for planner in (node.planner, node.service_planner, GlobalPlanner.from_params(node.plugins.global_params)):
        direct, r = _direct(planner, two_gaps)
        assert direct                                   # the gap's cost 40 x 0.1: straight through
        heading = np.arctan2(np.diff(r.path[:, 1]), np.diff(r.path[:, 0]))
        npt.assert_allclose(np.cos(r.yaws[1:-1] - heading[1:] - math.pi), 1.0, atol=0.05)
        assert r.yaws[-1] == pytest.approx(0.7)
        assert planner.config.allow_unknown is False    # the rest is kept
    assert any("GlobalPlanner reconfigured" in t for t in ros.infos)


def test_global_out_of_range_is_refused(monkeypatch):
    ros = FakeRos(monkeypatch)
    node = _fake_node()
    srv = _server(node, GP)
    cfg = srv.update_configuration({"cost_factor": 9.0, "orientation_mode": 7, "lethal_cost": 0})
    assert (cfg["cost_factor"], cfg["orientation_mode"], cfg["lethal_cost"]) == (3.0, 1, 253)
    assert node.planner.config == GlobalPlannerConfig()
    text = "\n".join(ros.warnings)
    assert "cost_factor = 9.0: valid range [0.01, 5.0]" in text and "orientation_mode = 7: valid range [0, 6]" in text


def test_global_callback_refuses_what_the_planner_refuses(monkeypatch):
    """The callback alone (no server range check): the planner's own ParamError is the message."""
    ros = FakeRos(monkeypatch)
    node = _fake_node()
    cb = rr.GlobalPlannerReconfigure(node.slots[0])
    config = {"lethal_cost": 253, "neutral_cost": 50, "cost_factor": 3.0, "publish_potential": True,
              "orientation_mode": 1, "orientation_window_size": 1}
    cb(dict(config), 0)
    out = cb(dict(config, neutral_cost=300), 0)
    assert out["neutral_cost"] == 50 and node.planner.config.neutral_cost == 50
    assert any("GlobalPlanner: 'neutral_cost' must be in [1, 255], got 300 (GlobalPlanner/neutral_cost)" in t for t in ros.warnings)


# -- choice of servers, the .cfg files -------------------------------------------------------------
@pytest.mark.parametrize("local, glob, expected", [
    (TPR, GP, ["~GlobalPlanner/", "~TrajectoryPlannerROS/"]),
    ("dwa_local_planner/DWAPlannerROS", "navfn/NavfnROS", ["~DWAPlannerROS/"]),
    (TPR, "navfn/NavfnROS", ["~TrajectoryPlannerROS/"]),
])
def test_servers_are_chosen_by_type(monkeypatch, local, glob, expected):
    FakeRos(monkeypatch)
    node = _fake_node(local_type=local, global_type=glob)
    assert sorted(s.ns for s in rr.start_servers(node.slots, (node.gcm, node.lcm))) == expected


def test_cfg_files_carry_the_real_names_and_global_planner_ranges():
    blp = rr.config_type("BaseLocalPlanner")
    fields = set(tp.TrajectoryPlannerConfig.__dataclass_fields__)
    assert set(blp.defaults) - fields == {"restore_defaults"}
    gpc = rr.config_type("GlobalPlanner")
    assert set(gpc.defaults) == {"lethal_cost", "neutral_cost", "cost_factor", "publish_potential",
                                 "orientation_mode", "orientation_window_size"}
    default = GlobalPlannerConfig()
    for name in gpc.defaults:
        assert getattr(default, name) == gpc.defaults[name], name
        if gpc.type[name] != "bool":
            assert _RANGES[name] == (gpc.min[name], gpc.max[name]), name
