"""NavFn: potential vs the slow reference Dijkstra, the gradient path, bad goals."""
import math

import numpy as np
import numpy.testing as npt
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D
from my_summit_path_planning.navfn import (POT_HIGH, GridGraph, NavFn, NavfnConfig, dijkstra_reference,
                                           grid_geodesic_length, navfn_costs)


def random_costs(rng, h, w):
    c = rng.integers(0, 253, size=(h, w)).astype(np.uint8)
    c[rng.random((h, w)) < 0.2] = cv.LETHAL_OBSTACLE
    c[rng.random((h, w)) < 0.05] = cv.NO_INFORMATION
    return c


@pytest.mark.parametrize("seed", range(5))
def test_potential_matches_reference_dijkstra(seed):
    rng = np.random.default_rng(seed)
    costs = random_costs(rng, 12, 15)
    for allow_unknown in (False, True):
        cc = navfn_costs(costs, allow_unknown)
        free = np.argwhere(np.isfinite(cc))
        sy, sx = free[rng.integers(len(free))]
        fast = GridGraph(cc).potential(sy * 15 + sx)
        slow = dijkstra_reference(cc.tolist(), (int(sx), int(sy)))
        npt.assert_allclose(fast, slow, rtol=1e-12)


def test_navfn_costs_translation():
    c = np.array([[0, 100, 252, 253, 254, 255]], np.uint8)
    out = navfn_costs(c, allow_unknown=True)
    npt.assert_array_equal(out[0, :3], [50, 130, 251])
    assert np.isinf(out[0, 3]) and np.isinf(out[0, 4]) and out[0, 5] == 253
    assert np.isinf(navfn_costs(c, allow_unknown=False)[0, 5])


def _maze(footprint, make_static_costmap):
    occ = np.zeros((80, 100), np.int8)
    occ[0, :] = occ[-1, :] = 100
    occ[:, 0] = occ[:, -1] = 100
    occ[:55, 30] = 100      # two walls with gaps at opposite ends
    occ[25:, 65] = 100
    occ[60:75, 80:95] = -1  # an unknown patch
    return make_static_costmap(occ, footprint)


def test_gradient_path_never_crosses_forbidden_cells(footprint, make_static_costmap):
    lc = _maze(footprint, make_static_costmap)
    cm = lc.master
    planner = NavFn(NavfnConfig(allow_unknown=False))
    rng = np.random.default_rng(7)
    free = np.argwhere(cm.data < cv.INSCRIBED_INFLATED_OBSTACLE)
    planned = 0
    for _ in range(15):
        a, b = free[rng.integers(len(free))], free[rng.integers(len(free))]
        r = planner.make_plan(cm, cm.map_to_world(a[1], a[0]), cm.map_to_world(b[1], b[0]))
        assert r.ok, r.reason
        planned += 1
        # Densely resample the path: every point on it must be in a cell below inscribed.
        p = r.path
        t = np.linspace(0, 1, 20)[:, None]
        seg = (p[:-1, None, :] * (1 - t[None]) + p[1:, None, :] * t[None]).reshape(-1, 2)
        mx, my, inside = cm.world_to_map_array(seg)
        assert inside.all()
        assert (cm.data[my, mx] < cv.INSCRIBED_INFLATED_OBSTACLE).all()
        geo = grid_geodesic_length(cm.data < cv.INSCRIBED_INFLATED_OBSTACLE, (a[1], a[0]), (b[1], b[0])) * cm.resolution
        assert r.length <= geo * 1.15 + 0.2
    assert planned == 15


def test_bad_goals_have_reasons(footprint, make_static_costmap):
    lc = _maze(footprint, make_static_costmap)
    cm = lc.master
    planner = NavFn(NavfnConfig(allow_unknown=False, default_tolerance=0.0))
    start = cm.map_to_world(10, 10)
    wall = cm.map_to_world(30, 20)
    r = planner.make_plan(cm, start, wall)
    assert not r.ok and "obstacle" in r.reason
    unknown = cm.map_to_world(88, 68)
    r = planner.make_plan(cm, start, unknown)
    assert not r.ok and "unknown" in r.reason
    r = planner.make_plan(cm, start, (100.0, 100.0))
    assert not r.ok and "off the costmap" in r.reason
    r = planner.make_plan(cm, start, (float("nan"), 1.0))
    assert not r.ok and "finite" in r.reason
    # With default_tolerance, a goal in the wall gets the nearest reachable cell instead.
    r = planner.make_plan(cm, start, wall, tolerance=0.6)
    assert r.ok
    gx, gy = r.goal
    assert math.hypot(gx - wall[0], gy - wall[1]) <= 0.6 * math.sqrt(2) + 1e-9
    assert cm.cost_at(gx, gy) < cv.INSCRIBED_INFLATED_OBSTACLE


def test_start_in_inflation_zone_still_plans(footprint, make_static_costmap):
    lc = _maze(footprint, make_static_costmap)
    cm = lc.master
    planner = NavFn(NavfnConfig(allow_unknown=False))
    start = cm.map_to_world(33, 20)          # 3 cells from the wall: inscribed zone
    assert cm.cost_at(*start) == cv.INSCRIBED_INFLATED_OBSTACLE
    r = planner.make_plan(cm, start, cm.map_to_world(50, 40))
    assert r.ok, r.reason
    lethal_start = cm.map_to_world(30, 20)
    r = planner.make_plan(cm, lethal_start, cm.map_to_world(50, 40))
    assert not r.ok and "lethal" in r.reason


def test_unreachable_goal():
    cm = Costmap2D(30, 30, 0.1)
    cm.data[:, 15] = cv.LETHAL_OBSTACLE
    r = NavFn().make_plan(cm, (0.5, 0.5), (2.5, 2.5))
    assert not r.ok and "not reachable" in r.reason


@pytest.mark.parametrize("kind", ["navfn", "global_planner"])
def test_a_start_in_a_wall_band_leaves_it_but_does_not_cut_through_the_wall(kind):
    """Field failure (closed-loop bench, willow-full-0.05, pair 20): the robot's centre in
    an inscribed cell (laser marks in a doorway) opened the whole connected inscribed
    region to the planner; along walls those bands join up, and between the cells of a
    wall drawn with gaps they join both sides: the plan led through the wall, DWA could not
    follow it, and the goal timed out. Here a wall of every other cell lethal, its
    inscribed band 3 cells either side, a door at the top; the robot in the band beside
    the wall: the plan leaves the band and goes round by the door."""
    from my_summit_path_planning.global_planner import GlobalPlanner, GlobalPlannerConfig
    from my_summit_path_planning.navfn import start_region
    cm = Costmap2D(100, 90, 0.1)
    cm.data[:70, 47:54] = cv.INSCRIBED_INFLATED_OBSTACLE
    cm.data[:70:2, 50] = cv.LETHAL_OBSTACLE           # the wall's cells, with gaps between
    start, goal = cm.map_to_world(48, 20), cm.map_to_world(60, 20)
    assert cm.cost_at(*start) == cv.INSCRIBED_INFLATED_OBSTACLE
    planner = NavFn(NavfnConfig(allow_unknown=False)) if kind == "navfn" else \
        GlobalPlanner(GlobalPlannerConfig(allow_unknown=False))
    r = planner.make_plan(cm, start, goal)
    assert r.ok, r.reason
    cells = np.floor((r.path - (cm.origin_x, cm.origin_y)) / cm.resolution).astype(int)
    crossing = (cells[:, 0] >= 49) & (cells[:, 0] <= 51) & (cells[:, 1] < 70)
    assert not crossing.any(), r.path[crossing][:3]       # round by the door, not through the wall
    assert r.length > 2 * 4.9
    # the region opened: the start's way out (2 cells to free space) and a little more
    forbidden = cm.data >= cv.INSCRIBED_INFLATED_OBSTACLE
    region = start_region(forbidden, cm.data == cv.LETHAL_OBSTACLE, (48, 20))
    assert region[20, 48] and region[20, 47] and not region[:, 50:].any()
    assert region.sum() <= 9 * 9
