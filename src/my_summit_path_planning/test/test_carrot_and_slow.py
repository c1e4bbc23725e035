"""The navigation stack's other two plugins: carrot_planner/CarrotPlanner and
move_slow_and_clear/MoveSlowAndClear, against their documented behaviour."""
import math

import numpy as np
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.carrot_planner import NO_TARGET, SCALES, CarrotPlanner
from my_summit_path_planning.costmap import Costmap2D, LayeredCostmap
from my_summit_path_planning.params import ParamError, move_base_params
from my_summit_path_planning.plugins import MoveBasePlugins
from my_summit_path_planning.recovery import MoveSlowAndClear
from my_summit_path_planning.trajectory_planner import footprint_cost_reference

DWA = "dwa_local_planner/DWAPlannerROS"


# -- carrot_planner ---------------------------------------------------------------------------
def open_costmap():
    """10 m x 6 m at 0.05 m, all free."""
    return Costmap2D(200, 120, 0.05, 0.0, 0.0)


def test_scales_are_the_real_loops():
    assert SCALES[0] == 1.0 and SCALES.size == 100
    assert 0.0 <= SCALES[-1] < 0.011 and np.all(np.diff(SCALES) < 0)


def test_a_free_goal_is_planned_to_as_given(footprint):
    r = CarrotPlanner(footprint).make_plan(open_costmap(), (1.0, 3.0, 0.0), (8.0, 2.0, 1.0))
    assert r.ok and r.reason == ""
    np.testing.assert_allclose(r.path, [[1.0, 3.0], [8.0, 2.0]])
    assert r.length == pytest.approx(math.hypot(7.0, 1.0))


def test_a_goal_in_a_wall_stops_at_the_first_legal_pose_before_it(footprint):
    cm = open_costmap()
    cm.data[:, 140:150] = cv.LETHAL_OBSTACLE            # a wall across x 7.0-7.5 m
    start, goal = (1.0, 3.0, 0.0), (7.2, 3.0, 0.0)
    planner = CarrotPlanner(footprint)
    r = planner.make_plan(cm, start, goal)
    assert r.ok
    tx, ty = r.path[-1]
    # the footprint (front edge 0.36 m ahead) clears the wall, one step further it does not
    poses = planner.targets(start, goal)
    k = int(np.flatnonzero(np.isclose(poses[:, 0], tx))[0])
    assert footprint_cost_reference(cm, footprint.polygon, *poses[k]) >= 0
    assert footprint_cost_reference(cm, footprint.polygon, *poses[k - 1]) < 0
    assert 7.0 - 0.36 - 0.062 < tx < 7.0 - 0.36 and ty == pytest.approx(3.0)   # steps of 1 % of 6.2 m
    assert planner.make_plan_reference(cm, start, goal)[:2] == pytest.approx((tx, ty))


def test_unknown_cells_are_not_legal_and_nothing_legal_fails(footprint):
    cm = Costmap2D(200, 120, 0.05, 0.0, 0.0, cv.NO_INFORMATION)
    r = CarrotPlanner(footprint).make_plan(cm, (1.0, 3.0, 0.0), (8.0, 3.0, 0.0))
    assert not r.ok and r.reason == NO_TARGET
    r = CarrotPlanner(footprint).make_plan(open_costmap(), (1.0, 3.0, 0.0), (9.9, 3.0, 0.0))
    assert r.ok and 10.0 - 0.36 - 0.09 < r.path[-1][0] < 10.0 - 0.36   # the footprint stays on the map
    r = CarrotPlanner(footprint).make_plan(open_costmap(), (1.0, 3.0, 0.0), (float("nan"), 3.0, 0.0))
    assert not r.ok and "not a finite pose" in r.reason


def test_matches_the_pose_by_pose_reference_on_random_costmaps(footprint):
    rng = np.random.default_rng(3)
    planner = CarrotPlanner(footprint)
    for _ in range(30):
        cm = open_costmap()
        for _ in range(6):
            x, y = rng.integers(0, 190), rng.integers(0, 110)
            cm.data[y:y + rng.integers(2, 12), x:x + rng.integers(2, 12)] = rng.choice(
                [cv.LETHAL_OBSTACLE, cv.NO_INFORMATION, cv.INSCRIBED_INFLATED_OBSTACLE, 100])
        start = (rng.uniform(0.5, 9.5), rng.uniform(0.5, 5.5), rng.uniform(-3, 3))
        goal = (rng.uniform(0.5, 9.5), rng.uniform(0.5, 5.5), rng.uniform(-3, 3))
        r, ref = planner.make_plan(cm, start, goal), planner.make_plan_reference(cm, start, goal)
        if ref is None:
            assert not r.ok
        else:
            assert r.ok and tuple(r.path[-1]) == pytest.approx(ref[:2])


def test_carrot_is_loaded_by_type_with_its_parameters(footprint):
    pl = MoveBasePlugins(move_base_params({
        "base_global_planner": "carrot_planner/CarrotPlanner", "base_local_planner": DWA,
        "CarrotPlanner": {"step_size": 0.05, "min_dist_from_robot": 0.1, "stepsize": 1}}), footprint=footprint)
    assert isinstance(pl.global_planner, CarrotPlanner) and pl.global_planner.step_size == 0.05
    assert any("'stepsize'" in n and "step_size" in n for n in pl.notes), pl.notes
    with pytest.raises(ParamError, match=r"CarrotPlanner: 'step_size' must be a finite number"):
        MoveBasePlugins(move_base_params({"base_global_planner": "carrot_planner/CarrotPlanner",
                                          "base_local_planner": DWA, "CarrotPlanner": {"step_size": "fine"}}),
                        footprint=footprint)


# -- move_slow_and_clear ------------------------------------------------------------------------
class Params:
    """The node's planner_params: a parameter server dict and the reconfigure calls made."""

    def __init__(self, server):
        self.server, self.calls = dict(server), []

    def get(self, namespace, name):
        return self.server.get(f"{namespace}/{name}")

    def set(self, namespace, values):
        self.calls.append((namespace, dict(values)))
        for k, v in values.items():
            if f"{namespace}/{k}" in self.server:      # dynamic_reconfigure ignores unknown names
                self.server[f"{namespace}/{k}"] = v


def marked(footprint, names=("obstacles", "obstacle_layer")):
    lc = LayeredCostmap.from_plugins([{"name": n, "type": "costmap_2d::ObstacleLayer"} for n in names],
                                     {n: {"observation_sources": ""} for n in names},
                                     Costmap2D(200, 200, 0.05, -5.0, -5.0), footprint)
    for n in names:
        lc.layer(n).grid.data[:] = cv.LETHAL_OBSTACLE
    return lc


def dwa_params():
    return Params({"DWAPlannerROS/max_vel_trans": 0.55, "DWAPlannerROS/max_vel_theta": 1.0})


def slow(footprint, handle, params, pose=(1.0, 0.0, 0.0), **kw):
    g, loc = handle(marked(footprint), pose, "global_costmap"), handle(marked(footprint), (0.0, 0.0, 0.0),
                                                                       "local_costmap")
    kw = {"max_trans_param_name": "max_vel_trans", "max_rot_param_name": "max_vel_theta", **kw}
    return MoveSlowAndClear(g, loc, params, **kw), g, loc


def test_clears_inside_the_square_in_the_obstacles_layers_only(footprint, costmap_handle):
    rec, g, loc = slow(footprint, costmap_handle, dwa_params())
    rec.start((0.0, 0.0, 0.0))
    assert rec.step((0.0, 0.0, 0.0)).done and rec.cleared == ["obstacles", "obstacles"]
    for h in (g, loc):
        x, y = h.pose[:2]
        ob, ol = h.layered.layer("obstacles").grid, h.layered.layer("obstacle_layer").grid
        assert ob.data[ob.world_to_map(x + 0.45, y - 0.45)[::-1]] == cv.FREE_SPACE     # inside: freed
        assert ob.data[ob.world_to_map(x + 0.6, y)[::-1]] == cv.LETHAL_OBSTACLE       # outside: kept
        assert np.all(ol.data == cv.LETHAL_OBSTACLE)     # 'obstacle_layer' is not an 'obstacles' layer
        assert int((ob.data == cv.FREE_SPACE).sum()) == 21 * 21   # x +- 0.5 m: cells -10..+10


def test_limits_the_speeds_until_the_robot_has_moved_then_restores_them(footprint, costmap_handle):
    params = dwa_params()
    rec, g, _ = slow(footprint, costmap_handle, params, limited_trans_speed=0.2, limited_rot_speed=0.4, limited_distance=0.3)
    step = rec.step((0.0, 0.0, 0.0))
    assert params.calls == [("DWAPlannerROS", {"max_vel_trans": 0.2, "max_vel_theta": 0.4})]
    assert "max_vel_trans 0.2" in step.reason and rec.limit_set
    g.pose = (1.25, 0.1, 0.0)                      # 0.27 m: still limited
    assert rec.tick() == "" and len(params.calls) == 1
    rec.step((0.0, 0.0, 0.0))                       # a second run keeps the first run's old values
    assert rec.old == {"max_vel_trans": 0.55, "max_vel_theta": 1.0}
    g.pose = (1.5, 0.1, 0.0)                        # 0.26 m from the second run's start
    assert rec.tick() == ""
    g.pose = (1.5, 0.35, 0.0)
    assert rec.tick() == "Moved far enough, removing speed limit."
    assert params.calls[-1] == ("DWAPlannerROS", {"max_vel_trans": 0.55, "max_vel_theta": 1.0})
    assert params.server["DWAPlannerROS/max_vel_trans"] == 0.55 and not rec.limit_set
    assert rec.tick() == "" and len(params.calls) == 3


def test_the_real_defaults_name_parameters_dwa_no_longer_has(footprint, costmap_handle):
    params = dwa_params()
    rec, _, _ = slow(footprint, costmap_handle, params, max_trans_param_name="max_trans_vel", max_rot_param_name="max_rot_vel")
    step = rec.step((0.0, 0.0, 0.0))
    assert "The planner ~DWAPlannerROS, does not have the parameter max_trans_vel" in step.reason
    assert params.server["DWAPlannerROS/max_vel_trans"] == 0.55      # unchanged: the names are unknown
    rec.global_costmap.pose = (5.0, 0.0, 0.0)
    rec.tick()
    assert params.calls[-1][1] == {"max_trans_vel": 0.25, "max_rot_vel": 0.45}   # nothing to restore


def test_loaded_by_type_with_notes_and_bad_values(footprint, costmap_handle):
    g, loc = costmap_handle(marked(footprint, ("obstacle_layer",)), (0, 0, 0), "global_costmap"), None
    p = move_base_params({"base_local_planner": DWA, "recovery_behaviors": [
        {"name": "slow", "type": "move_slow_and_clear/MoveSlowAndClear"}],
        "slow": {"limited_trans_speed": 0.1, "limited_distanc": 1.0}})
    pl = MoveBasePlugins(p, g, loc, footprint=footprint, planner_params=dwa_params())
    (name, beh), = pl.recoveries
    assert name == "slow" and isinstance(beh, MoveSlowAndClear) and pl.recovery_error == ""
    assert beh.limits == {"max_trans_vel": 0.1, "max_rot_vel": 0.45} and beh.namespace == "DWAPlannerROS"
    assert any("'limited_distanc'" in n and "limited_distance" in n for n in pl.notes), pl.notes
    assert any("global_costmap has none (obstacle_layer)" in n for n in pl.notes), pl.notes
    p = move_base_params({"base_local_planner": DWA, "recovery_behaviors": [
        {"name": "slow", "type": "move_slow_and_clear/MoveSlowAndClear"}], "slow": {"limited_distance": "far"}})
    pl = MoveBasePlugins(p, g, loc, footprint=footprint)
    assert "slow: 'limited_distance' must be a number, got 'far'" in pl.recovery_error
