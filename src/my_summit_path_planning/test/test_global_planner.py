"""global_planner/GlobalPlanner: expansion vs the slow reference, A* vs Dijkstra, the path
makers, the orientation filter, the cost parameters, errors and parameters."""
import math

import numpy as np
import numpy.testing as npt
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra as sp_dijkstra

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D
from my_summit_path_planning.global_planner import (
    BACKWARD, FORWARD, FORWARD_THEN_INTERPOLATE, HEURISTIC_WEIGHT, INTERPOLATE, LEFTWARD, NONE, POT_HIGH,
    RIGHTWARD, GlobalPlanner, GlobalPlannerConfig, expand as compiled_expand, orientation_filter, planner_costs,
    potential_reference, potential_to_occupancy)
from my_summit_path_planning.navfn import NavFn, NavfnConfig, grid_geodesic_length
from my_summit_path_planning.param_reader import UNREAD
from my_summit_path_planning.params import ParamError


def random_costs(rng, h, w, lethal_share=0.15):
    c = rng.integers(0, 253, size=(h, w)).astype(np.uint8)
    c[rng.random((h, w)) < lethal_share] = cv.LETHAL_OBSTACLE
    return c


def expand(cost, seeds, goal, heuristic, quadratic):
    """The compiled expand on an (H, W) cost grid; seeds {(x, y): potential}; goal (x, y) or None."""
    h, w = cost.shape
    pot = np.full(h * w, POT_HIGH)
    cells = np.array([y * w + x for x, y in seeds], np.int64)
    ok, n = compiled_expand(cost.ravel(), w, h, cells, np.array(list(seeds.values()), np.float64),
                            -1 if goal is None else goal[1] * w + goal[0], heuristic, quadratic, pot)
    return ok, n, pot.reshape(h, w)


def plan_cost(path, cost, resolution):
    """Cell cost integrated along a world path on an origin-(0, 0) grid [cost x cells]."""
    p = np.asarray(path) / resolution
    seg = np.diff(p, axis=0)
    total = 0.0
    for a, d in zip(p[:-1], seg):
        n = max(1, int(math.ceil(np.hypot(*d) / 0.1)))
        t = (np.arange(n) + 0.5) / n
        q = np.floor(a + t[:, None] * d).astype(int)
        total += cost[q[:, 1], q[:, 0]].sum() * np.hypot(*d) / n
    return total


# ----- the expansion ------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("quadratic", [True, False])
@pytest.mark.parametrize("astar", [False, True])
def test_expansion_matches_slow_reference(seed, quadratic, astar):
    rng = np.random.default_rng(seed)
    # (a fraction of a unit more on each cell, so that no two cells tie in the heap: the
    # quadratic update depends on the order of acceptance)
    cost = planner_costs(random_costs(rng, 14, 17), allow_unknown=True) + rng.uniform(0, 1, (14, 17))
    free = [tuple(int(v) for v in p[::-1]) for p in np.argwhere(np.isfinite(cost))]
    s, g = free[rng.integers(len(free))], free[rng.integers(len(free))]
    seeds = {s: 0.0}
    nb = (s[0] + 1, s[1])
    if nb in free:
        seeds[nb] = 17.5  # a second, precise-start-like seed
    heur = HEURISTIC_WEIGHT * 50 if astar else 0.0
    for goal in (g, None):
        ok, _, pot = expand(cost, seeds, goal, heur, quadratic)
        ref, accepted = potential_reference(cost, seeds, goal, heur, quadratic)
        assert ok == (goal is not None and bool(accepted[g[1], g[0]]))
        npt.assert_allclose(pot[accepted], ref[accepted], rtol=1e-12)
        if goal is None:  # (with an early stop, which cells were seen depends on tie order)
            npt.assert_array_equal(pot < POT_HIGH, ref < POT_HIGH)


@pytest.mark.parametrize("seed", range(4))
def test_simple_update_is_node_weighted_dijkstra(seed):
    """use_quadratic false: the potential is the 4-connected shortest path, each cell
    entered costing its cell cost (SciPy's Dijkstra as an independent oracle)."""
    rng = np.random.default_rng(seed)
    h, w = 25, 31
    cost = planner_costs(random_costs(rng, h, w))
    s = tuple(int(v) for v in np.argwhere(np.isfinite(cost))[0][::-1])
    _, _, pot = expand(cost, {s: 0.0}, None, 0.0, False)
    rows, cols, wts = [], [], []
    for y in range(h):
        for x in range(w):
            for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                nx_, ny_ = x + dx, y + dy
                if 0 <= nx_ < w and 0 <= ny_ < h and np.isfinite(cost[y, x]) and np.isfinite(cost[ny_, nx_]):
                    rows.append(y * w + x)
                    cols.append(ny_ * w + nx_)
                    wts.append(cost[ny_, nx_])
    m = sp.csr_matrix((wts, (rows, cols)), shape=(h * w, h * w))
    d = sp_dijkstra(m, indices=s[1] * w + s[0]).reshape(h, w)
    reached = np.isfinite(d)
    npt.assert_array_equal(pot < POT_HIGH, reached)
    npt.assert_allclose(pot[reached], d[reached], rtol=1e-12)


@pytest.mark.parametrize("quadratic", [True, False])
def test_astar_plans_the_dijkstra_path_on_random_costmaps(quadratic):
    """Same goal potential and path cost, fewer cells expanded. With the quadratic update a
    cell's potential depends on whether its second neighbour was reached before it, so
    A*'s order can move potentials by a few 1e-4 (relative); the simple update is exact."""
    compared = 0
    for seed in range(12):
        rng = np.random.default_rng(100 + seed)
        data = random_costs(rng, 50, 60, lethal_share=0.12)
        data[:, 25] = np.where(rng.random(50) < 0.7, cv.LETHAL_OBSTACLE, data[:, 25])  # a porous wall
        cm = Costmap2D(60, 50, 0.1)
        cm.data[:] = data
        cost = planner_costs(data, cost_factor=1.0)
        free = np.argwhere(np.isfinite(cost[1:-1, 1:-1])) + 1
        a, b = free[rng.integers(len(free))], free[rng.integers(len(free))]
        start, goal = cm.map_to_world(a[1], a[0]), cm.map_to_world(b[1], b[0])
        # A*'s cells weigh the raw cost (AStarExpansion): Dijkstra's with cost_factor 1
        dij = GlobalPlanner(GlobalPlannerConfig(use_quadratic=quadratic, cost_factor=1.0))
        ast = GlobalPlanner(GlobalPlannerConfig(use_quadratic=quadratic, use_dijkstra=False))
        rd, ra = dij.make_plan(cm, start, goal), ast.make_plan(cm, start, goal)
        assert rd.ok == ra.ok, (rd.reason, ra.reason)
        if not rd.ok:
            continue
        compared += 1
        pd, pa = rd.potential[b[0], b[1]], ra.potential[b[0], b[1]]
        if quadratic:
            npt.assert_allclose(pa, pd, rtol=2e-3)
            npt.assert_allclose(plan_cost(ra.path, cost, 0.1), plan_cost(rd.path, cost, 0.1), rtol=0.03)
        else:
            npt.assert_allclose(pa, pd, rtol=1e-12)
        assert ast.cells_expanded <= dij.cells_expanded
    assert compared >= 8


# ----- paths ---------------------------------------------------------------------------------

def _maze(footprint, make_static_costmap):
    occ = np.zeros((80, 100), np.int8)
    occ[0, :] = occ[-1, :] = 100
    occ[:, 0] = occ[:, -1] = 100
    occ[:55, 30] = 100      # two walls with gaps at opposite ends
    occ[25:, 65] = 100
    occ[60:75, 80:95] = -1  # an unknown patch
    return make_static_costmap(occ, footprint)


def _cells_along(cm, path, per_segment=20):
    p = np.asarray(path)
    t = np.linspace(0, 1, per_segment)[:, None]
    seg = (p[:-1, None, :] * (1 - t[None]) + p[1:, None, :] * t[None]).reshape(-1, 2)
    mx, my, inside = cm.world_to_map_array(seg)
    assert inside.all()
    return cm.data[my, mx]


@pytest.mark.parametrize("use_dijkstra", [True, False])
def test_gradient_path_never_crosses_forbidden_cells(footprint, make_static_costmap, use_dijkstra):
    cm = _maze(footprint, make_static_costmap).master
    planner = GlobalPlanner(GlobalPlannerConfig(allow_unknown=False, use_dijkstra=use_dijkstra))
    rng = np.random.default_rng(7)
    free = np.argwhere(cm.data < cv.MAX_NON_OBSTACLE)
    for _ in range(12):
        a, b = free[rng.integers(len(free))], free[rng.integers(len(free))]
        start, goal = cm.map_to_world(a[1], a[0]), cm.map_to_world(b[1], b[0])
        r = planner.make_plan(cm, start, goal)
        assert r.ok, r.reason
        npt.assert_allclose(r.path[0], start)
        npt.assert_allclose(r.path[-1], goal)
        assert (_cells_along(cm, r.path) < cv.MAX_NON_OBSTACLE).all()  # lethal_cost 253: 252 is forbidden too
        geo = grid_geodesic_length(cm.data < cv.INSCRIBED_INFLATED_OBSTACLE, (a[1], a[0]), (b[1], b[0]))
        assert r.length <= geo * cm.resolution * 1.15 + 0.2
        assert len(r.yaws) == len(r.path)


def test_grid_path_is_a_cell_path(footprint, make_static_costmap):
    cm = _maze(footprint, make_static_costmap).master
    planner = GlobalPlanner(GlobalPlannerConfig(use_grid_path=True))
    start, goal = cm.map_to_world(10, 10), cm.map_to_world(90, 12)
    start = (start[0] + 0.013, start[1] - 0.02)
    r = planner.make_plan(cm, start, goal)
    assert r.ok, r.reason
    npt.assert_allclose(r.path[0], start)
    npt.assert_allclose(r.path[-1], goal)
    inner = (r.path[1:-1] - [cm.origin_x, cm.origin_y]) / cm.resolution - 0.5
    npt.assert_allclose(inner, np.round(inner), atol=1e-9)  # cell centres
    step = np.abs(np.diff(np.round(inner), axis=0))
    assert step.max() == 1 and (step.sum(axis=1) >= 1).all()  # 8-neighbours, no repeats
    assert (_cells_along(cm, r.path[1:-1]) < cv.MAX_NON_OBSTACLE).all()


def test_gradient_path_is_straight_in_the_open():
    cm = Costmap2D(60, 40, 0.1)
    r = GlobalPlanner().make_plan(cm, (0.55, 0.85), (5.05, 3.15))
    assert r.ok
    d = np.array([5.05 - 0.55, 3.15 - 0.85])
    off = np.abs(np.cross(d / np.linalg.norm(d), r.path - [0.55, 0.85]))
    assert off.max() < 0.1  # [m] within a cell of the straight line (the 4-connected update bows it)
    assert r.length <= np.linalg.norm(d) * 1.01


# ----- orientations --------------------------------------------------------------------------

def _corridor():
    cm = Costmap2D(60, 5, 0.1)
    cm.data[0, :] = cm.data[-1, :] = cv.LETHAL_OBSTACLE
    return cm


@pytest.mark.parametrize("mode, expected", [
    (NONE, 0.0), (FORWARD, 0.0), (BACKWARD, math.pi), (LEFTWARD, -math.pi / 2), (RIGHTWARD, math.pi / 2)])
def test_orientation_modes_on_a_straight_path(mode, expected):
    cm = _corridor()
    planner = GlobalPlanner(GlobalPlannerConfig(orientation_mode=mode))
    r = planner.make_plan(cm, (0.35, 0.25, 0.3), (5.45, 0.25, 1.0))
    assert r.ok
    npt.assert_allclose(r.path[:, 1], 0.25, atol=1e-9)  # the corridor's middle row
    assert r.yaws[-1] == pytest.approx(1.0)
    diff = (r.yaws[:-1] - expected + math.pi) % (2 * math.pi) - math.pi
    npt.assert_allclose(diff, 0.0, atol=1e-9)


@pytest.mark.parametrize("mode", [INTERPOLATE, FORWARD_THEN_INTERPOLATE])
def test_interpolated_orientations_on_a_straight_path(mode):
    """On a straight path the last straight stretch is all of it: both modes blend the
    start yaw into the goal yaw along the path."""
    cm = _corridor()
    r = GlobalPlanner(GlobalPlannerConfig(orientation_mode=mode)).make_plan(cm, (0.35, 0.25, 0.3),
                                                                          (5.45, 0.25, 1.0))
    assert r.ok
    npt.assert_allclose(r.yaws, np.linspace(0.3, 1.0, len(r.yaws)), atol=1e-9)


def test_forward_then_interpolate_blends_over_the_last_straight_stretch():
    # an L: 5 points east, then 6 points north
    xy = np.array([[i, 0.0] for i in range(5)] + [[4.0, j] for j in range(1, 7)])
    yaws = orientation_filter(xy, 2.0, -1.0, FORWARD_THEN_INTERPOLATE)
    # points 1..3 head east (window 1); from point 4 (the corner) the heading is north
    npt.assert_allclose(yaws[1:4], 0.0, atol=1e-12)
    assert yaws[0] == pytest.approx(2.0)  # the start pose keeps the start yaw
    corner_dir = math.atan2(1, 1)         # point 4 looks from point 3 to point 5
    assert yaws[4] == pytest.approx(corner_dir)
    # blended from point 5 (the first of the straight stretch north) to the goal yaw
    npt.assert_allclose(yaws[5:], np.linspace(math.pi / 2, -1.0, 6), atol=1e-12)


def test_orientation_window_size():
    xy = np.array([[0, 0], [1, 0], [2, 1], [3, 1], [4, 1]], float)
    w1 = orientation_filter(xy, 0.0, 0.0, FORWARD, window=1)
    w2 = orientation_filter(xy, 0.0, 0.0, FORWARD, window=2)
    assert w1[1] == pytest.approx(math.atan2(1, 2))   # points 0 -> 2
    assert w2[1] == pytest.approx(math.atan2(1, 3))   # points 0 -> 3 (clipped at 0)
    assert w2[2] == pytest.approx(math.atan2(1, 4))   # points 0 -> 4


# ----- cost parameters -----------------------------------------------------------------------

def test_cell_cost_translation():
    c = np.array([0, 10, 67, 68, 251, 252, 253, 254, 255], np.uint8)
    npt.assert_array_equal(planner_costs(c), [50, 80, 251, 252, 252, np.inf, np.inf, np.inf, 252])
    assert np.isinf(planner_costs(c, allow_unknown=False)[-1])
    npt.assert_array_equal(planner_costs(c, lethal_cost=100, neutral_cost=10, cost_factor=1.0)[:4],
                           [10, 20, 77, 78])
    out = planner_costs(np.array([97, 98, 99], np.uint8), lethal_cost=100, neutral_cost=10, cost_factor=1.0)
    npt.assert_array_equal(out, [99, 99, np.inf])  # capped at lethal_cost - 1; 99 and up forbidden


@pytest.mark.parametrize("params, direct, astar_direct", [
    ({}, False, False),                                      # 5 x (40 x 3) and 5 x 40 > the detour's ~2.7 x 50
    ({"cost_factor": 0.1}, True, False),                     # 5 x 4 < 2.7 x 50; A* weighs the raw 40
    ({"neutral_cost": 255}, True, True),                     # 5 x 120 and 5 x 40 < 2.7 x 255
    ({"cost_factor": 0.1, "lethal_cost": 40}, False, False),  # cost 40 >= lethal_cost - 1: forbidden
])
def test_lethal_neutral_and_cost_factor_choose_the_route(params, direct, astar_direct, two_gaps):
    """Dijkstra weighs a cell c * cost_factor + neutral_cost, A* (AStarExpansion) c +
    neutral_cost whatever cost_factor says."""
    cm = two_gaps.costmap()
    for use_dijkstra, expect in ((True, direct), (False, astar_direct)):
        planner = GlobalPlanner.from_params(dict(params, use_dijkstra=use_dijkstra))
        r = planner.make_plan(cm, (0.25, 1.05), (3.75, 1.05))
        assert r.ok, r.reason
        assert two_gaps.through_direct_gap(r) == expect, use_dijkstra


def test_allow_unknown_false_refuses_unknown_space():
    cm = Costmap2D(40, 20, 0.1)
    cm.data[:, 20:23] = cv.NO_INFORMATION  # unknown across the whole map
    start, goal = (0.5, 1.0), (3.5, 1.0)
    assert GlobalPlanner(GlobalPlannerConfig(allow_unknown=True)).make_plan(cm, start, goal).ok
    r = GlobalPlanner(GlobalPlannerConfig(allow_unknown=False)).make_plan(cm, start, goal)
    assert not r.ok and "not reachable" in r.reason
    r = GlobalPlanner(GlobalPlannerConfig(allow_unknown=False)).make_plan(cm, start, (2.15, 1.0))
    assert not r.ok and r.reason == "goal is in unknown space and allow_unknown is false"


# ----- make_plan's contract (NavFn's) ----------------------------------------------------------

@pytest.mark.parametrize("goal_cell, extra", [
    ((30, 20), None), ((88, 68), None), ((33, 20), None), (None, (100.0, 100.0)), (None, (float("nan"), 1.0))])
def test_errors_read_as_navfn_s(footprint, make_static_costmap, goal_cell, extra):
    cm = _maze(footprint, make_static_costmap).master
    start = cm.map_to_world(10, 10)
    goal = cm.map_to_world(*goal_cell) if goal_cell else extra
    r = GlobalPlanner(GlobalPlannerConfig(allow_unknown=False)).make_plan(cm, start, goal)
    expected = NavFn(NavfnConfig(allow_unknown=False)).make_plan(cm, start, goal)
    assert not r.ok and not expected.ok
    assert r.reason == expected.reason


def test_unreachable_goal_and_lethal_start():
    cm = Costmap2D(30, 30, 0.1)
    cm.data[:, 15] = cv.LETHAL_OBSTACLE
    r = GlobalPlanner().make_plan(cm, (0.5, 0.5), (2.5, 2.5))
    # NavFn's text; the start's side is 14 x 28 cells, not 15 x 30: outline_map closes the border
    assert not r.ok and r.reason == NavFn().make_plan(cm, (0.5, 0.5), (2.5, 2.5)).reason.replace(
        "450 cells, 4.50", "392 cells, 3.92")
    r = GlobalPlanner().make_plan(cm, (1.55, 0.5), (0.5, 2.5))
    assert not r.ok and r.reason == "start is in a lethal cell (the robot is in collision)"


def test_tolerance_falls_back_to_default_tolerance(footprint, make_static_costmap):
    cm = _maze(footprint, make_static_costmap).master
    start, wall = cm.map_to_world(10, 10), cm.map_to_world(30, 20)
    for planner, tol in ((GlobalPlanner(), 0.6), (GlobalPlanner(GlobalPlannerConfig(default_tolerance=0.6)), None)):
        r = planner.make_plan(cm, start, wall, tolerance=tol)
        assert r.ok, r.reason
        assert max(abs(r.goal[0] - wall[0]), abs(r.goal[1] - wall[1])) <= 0.6 + 1e-9
        assert cm.cost_at(*r.goal) < cv.MAX_NON_OBSTACLE
        npt.assert_allclose(r.path[-1], r.goal)
    r = GlobalPlanner(GlobalPlannerConfig(default_tolerance=0.6)).make_plan(cm, start, wall, tolerance=0.0)
    assert not r.ok and "obstacle" in r.reason


def test_start_in_the_inscribed_zone_still_plans(footprint, make_static_costmap):
    cm = _maze(footprint, make_static_costmap).master
    start = cm.map_to_world(33, 20)
    assert cm.cost_at(*start) == cv.INSCRIBED_INFLATED_OBSTACLE
    before = cm.data.copy()
    r = GlobalPlanner(GlobalPlannerConfig(allow_unknown=False)).make_plan(cm, start, cm.map_to_world(50, 40))
    assert r.ok, r.reason
    npt.assert_array_equal(cm.data, before)  # the costmap is not modified


def test_old_navfn_behavior_uses_cell_corners():
    cm = Costmap2D(40, 20, 0.1)
    r = GlobalPlanner(GlobalPlannerConfig(old_navfn_behavior=True)).make_plan(cm, (0.57, 0.53), (3.26, 1.44))
    assert r.ok
    npt.assert_allclose(r.path[0], (0.5, 0.5))      # navfn's map -> world: the cell's corner
    npt.assert_allclose(r.path[-2], (3.2, 1.4))     # the goal cell, then the goal pose
    npt.assert_allclose(r.path[-1], (3.26, 1.44))


def test_potential_is_kept_for_publishing():
    cm = Costmap2D(40, 20, 0.1)
    cm.data[:, 30] = cv.LETHAL_OBSTACLE
    planner = GlobalPlanner()
    r = planner.make_plan(cm, (0.5, 1.0), (2.5, 1.0))
    assert r.potential is planner.potential and r.potential.shape == (20, 40)
    assert r.potential[10, 4] < 50 and (r.potential[:, 30] >= POT_HIGH).all()
    grid = potential_to_occupancy(r.potential, 100)
    assert grid.max() == 100 and (grid[:, 30] == -1).all() and grid.dtype == np.int8
    quiet = GlobalPlanner(GlobalPlannerConfig(publish_potential=False))
    assert quiet.make_plan(cm, (0.5, 1.0), (2.5, 1.0)).potential is None and quiet.potential is None


# ----- parameters ----------------------------------------------------------------------------

def test_from_params_defaults_and_unknown_keys():
    p = GlobalPlanner.from_params({"use_dijkstra": False, "cost_factor": 1, "planner_costmap_publish_frequency": 1.0,
                                   "foo": 2})
    assert p.config.use_dijkstra is False and p.config.cost_factor == 1.0
    assert tuple(n.param for n in p.notes if n.kind == UNREAD) == ("foo", "planner_costmap_publish_frequency")
    d = GlobalPlanner.from_params(None).config
    assert (d.allow_unknown, d.default_tolerance, d.visualize_potential, d.use_dijkstra, d.use_quadratic,
            d.use_grid_path, d.old_navfn_behavior, d.lethal_cost, d.neutral_cost, d.cost_factor,
            d.publish_potential, d.orientation_mode, d.orientation_window_size, d.outline_map) == \
        (True, 0.0, False, True, True, False, False, 253, 50, 3.0, True, 1, 1, True)
    assert "use_grid_path" in GlobalPlanner.KNOWN_PARAMS


@pytest.mark.parametrize("key, value, expected", [
    ("use_dijkstra", "yes", "bool"), ("neutral_cost", 50.5, "int"), ("cost_factor", "3", "float"),
    ("allow_unknown", 1, "bool"), ("orientation_mode", True, "int"),
    ("lethal_cost", 256, "[1, 255]"), ("cost_factor", 6.0, "[0.01, 5.0]"), ("orientation_mode", 7, "[0, 6]"),
    ("default_tolerance", -0.1, "[0.0, inf]"), ("orientation_window_size", 0, "[1, 255]")])
def test_bad_parameters_name_the_parameter(key, value, expected):
    with pytest.raises(ParamError) as e:
        GlobalPlanner.from_params({key: value}, "move_base/GlobalPlanner")
    assert f"move_base/GlobalPlanner/{key}" in str(e.value) and expected in str(e.value)
    with pytest.raises(ParamError, match="mapping"):
        GlobalPlanner.from_params([("use_dijkstra", True)])
