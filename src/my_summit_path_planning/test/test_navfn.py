"""NavFn: potential vs the slow reference Dijkstra, the gradient path, bad goals."""
import math

import numpy as np
import numpy.testing as npt
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D
from my_summit_path_planning.navfn import (POT_HIGH, GridGraph, NavFn, NavfnConfig, _reduced_weights,
                                           dijkstra_reference, grid_geodesic_length, grid_graph_matrix_reference,
                                           navfn_costs, reduced_weights_reference)


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


@pytest.mark.parametrize("seed", range(3))
def test_reduced_weights_equal_the_numpy_reference(seed):
    """A*'s reduced edge weights (one compiled pass over the CSR rows) against the NumPy
    gather / repeat (the former hot path: 40 ms of a 100 ms willow plan), heuristics that
    are consistent and one that is not (the clip at 0)."""
    rng = np.random.default_rng(seed)
    g = GridGraph(navfn_costs(random_costs(rng, 40, 37), True))
    for heur in (rng.uniform(0.0, 50.0, g.cells.size), np.zeros(g.cells.size), rng.uniform(0, 1e4, g.cells.size)):
        npt.assert_array_equal(_reduced_weights(g.matrix.indptr, g.matrix.indices, g.matrix.data, heur),
                               reduced_weights_reference(g.matrix, heur))


@pytest.mark.parametrize("seed", range(4))
def test_graph_matrix_equals_reference_bit_for_bit(seed):
    """The one-pass CSR build: the same rows, columns in the same order and the same weights
    as the matrix SciPy makes from the edge lists, so Dijkstra sees the same graph; the
    connected components (cv2, 8-connected cells) the same partition as SciPy's."""
    from scipy.sparse.csgraph import connected_components
    rng = np.random.default_rng(seed)
    h, w = [(1, 1), (1, 9), (23, 31), (60, 47)][seed]
    costs = random_costs(rng, h, w)
    costs[:, w // 2] = cv.LETHAL_OBSTACLE      # a wall: two components at least
    for allow_unknown in (False, True):
        cc = navfn_costs(costs, allow_unknown)
        g, ref = GridGraph(cc), grid_graph_matrix_reference(cc)
        ref.sort_indices()
        npt.assert_array_equal(g.matrix.indptr, ref.indptr)
        npt.assert_array_equal(g.matrix.indices, ref.indices)
        npt.assert_array_equal(g.matrix.data, ref.data)
        _, labels = connected_components(ref, directed=False)
        ours = np.array([g.component_of(c) for c in g.cells])
        assert len(set(zip(ours, labels))) == len(set(ours)) == len(set(labels))
        assert all(g.component_of(c) == -1 for c in np.flatnonzero(~np.isfinite(cc).ravel()))
        if seed >= 2:
            assert len(set(labels)) > 1 and g.matrix.nnz > 0    # several components, edges

@pytest.mark.parametrize("seed", range(4))
def test_compiled_dijkstra_equals_scipys_to_the_bit(seed):
    """The compiled Dijkstra (csrc/grid_graph.c) that replaced scipy.sparse.csgraph's in
    the node: the same distances to the bit, with a distance limit and on A*'s reduced
    weights, whose rounding leaves explicit zero-weight edges (SciPy keeps them as edges)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import dijkstra as sp_dijkstra
    from my_summit_path_planning.navfn import CSRGraph, _dijkstra
    rng = np.random.default_rng(seed)
    g = GridGraph(navfn_costs(random_costs(rng, 50, 43), True))
    m = g.matrix
    heur = rng.uniform(0.0, 1e4, g.cells.size)            # not consistent: many zeros after the clip
    reduced = _reduced_weights(m.indptr, m.indices, m.data, heur)
    assert np.count_nonzero(reduced == 0.0) > 0
    for data in (m.data, reduced):
        ref = sp.csr_matrix((data, m.indices, m.indptr), shape=m.shape)
        src = int(rng.integers(g.cells.size))
        full = sp_dijkstra(ref, directed=True, indices=src)
        for limit in (np.inf, float(np.median(full[np.isfinite(full)])), 0.0):
            npt.assert_array_equal(_dijkstra(CSRGraph(data, m.indices, m.indptr, m.shape[0]), src, limit),
                                   sp_dijkstra(ref, directed=True, indices=src, limit=limit))


@pytest.mark.parametrize("seed", range(4))
def test_grid_dijkstra_equals_scipys_on_the_matrix_to_the_bit(seed):
    """The planner's search on the grid itself (weights computed where used, no CSR
    matrix) gives SciPy's Dijkstra distances on GridGraph's matrix to the bit: plain, and
    on A*'s reduced weights (the heuristic's rounding leaves zero-weight edges), with and
    without a limit."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import dijkstra as sp_dijkstra
    rng = np.random.default_rng(seed)
    g = GridGraph(navfn_costs(random_costs(rng, 45, 52), True))
    m = g.matrix
    heur_nodes = rng.uniform(0.0, 3e3, g.cells.size)
    heur = np.zeros(g.shape[0] * g.shape[1])
    heur[g.cells] = heur_nodes
    for h_nodes, h_cells in ((None, None), (heur_nodes, heur)):
        data = m.data if h_nodes is None else _reduced_weights(m.indptr, m.indices, m.data, h_nodes)
        ref = sp.csr_matrix((data, m.indices, m.indptr), shape=m.shape)
        src = int(rng.integers(g.cells.size))
        for limit in (np.inf, 2e3, 0.0):
            want = sp_dijkstra(ref, directed=True, indices=src, limit=limit)
            got = g._search(int(g.cells[src]), h_cells, limit)
            npt.assert_array_equal(got[g.cells], want)
            assert np.isinf(np.delete(got, g.cells)).all()


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


def test_unreachable_goal_names_the_start_s_free_region():
    """The reason says how much the start can reach: the left 15 of 30 columns here (a
    robot boxed in by stale marks shows as a few cells)."""
    cm = Costmap2D(30, 30, 0.1)
    cm.data[:, 15] = cv.LETHAL_OBSTACLE
    r = NavFn().make_plan(cm, (0.5, 0.5), (2.5, 2.5))
    assert not r.ok and "not reachable" in r.reason
    assert "the start's free region: 450 cells, 4.50 m^2" in r.reason
    cm.data[2:5, 2:5] = cv.LETHAL_OBSTACLE
    cm.data[3, 3] = cv.FREE_SPACE
    r = NavFn().make_plan(cm, (0.35, 0.35), (2.5, 2.5))
    assert not r.ok and "the start's free region: 1 cells, 0.01 m^2" in r.reason


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


def start_region_reference(forbidden, lethal, sc):
    """start_region's breadth-first part the slow, obvious way (a queue and a visited set),
    on the same depths: the oracle."""
    import collections
    import cv2
    from my_summit_path_planning.global_plan import START_REGION_SLACK
    h, w = forbidden.shape
    depth = cv2.distanceTransform(forbidden.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    d0 = float(depth[sc[1], sc[0]])
    steps = max(START_REGION_SLACK, int(math.ceil(2.0 * d0)))
    region = np.zeros((h, w), bool)
    region[sc[1], sc[0]] = True
    queue = collections.deque([(sc[0], sc[1], 0)])
    while queue:
        x, y, k = queue.popleft()
        if k == steps:
            continue
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                nx, ny = x + dx, y + dy
                if 0 <= nx < w and 0 <= ny < h and not region[ny, nx] and forbidden[ny, nx] \
                        and not lethal[ny, nx] and depth[ny, nx] <= d0 + 1e-6:
                    region[ny, nx] = True
                    queue.append((nx, ny, k + 1))
    return region


@pytest.mark.parametrize("seed", range(6))
def test_start_region_matches_a_plain_breadth_first_search(seed):
    import cv2
    from my_summit_path_planning.navfn import start_region
    rng = np.random.default_rng(seed)
    forbidden = np.zeros((60, 70), bool)
    for _ in range(8):   # overlapping forbidden blocks, some lethal cells inside
        x, y = rng.integers(0, 60), rng.integers(0, 50)
        forbidden[y:y + rng.integers(5, 30), x:x + rng.integers(5, 30)] = True
    lethal = forbidden & (rng.random(forbidden.shape) < 0.05)
    # starts up to 6 cells deep (a regression to an exploding frontier stays seconds)
    depth = cv2.distanceTransform(forbidden.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    cells = np.argwhere(forbidden & ~lethal & (depth <= 6))
    for y, x in cells[rng.choice(len(cells), 5, replace=False)]:
        npt.assert_array_equal(start_region(forbidden, lethal, (x, y)),
                               start_region_reference(forbidden, lethal, (x, y)))


def test_start_region_deep_in_a_forbidden_block_takes_no_time():
    """Field failure (move_base_recovery_list.test at 4x, 3 of 10 runs): the robot boxed in
    by a ring of boxes that are not in the map; amcl, seeing only the ring, lost its pose,
    the ring's laser marks landed in the global costmap around wrong map poses, and the
    robot's centre ended 7 to 23 cells deep in their inscribed band. start_region's
    breadth-first frontier held a cell once per frontier neighbour that reached it, so it
    multiplied at each of its 2 x depth steps (about 7x per cell of depth: 2 to 9 s at
    depth 7, a minute and gigabytes at depth 8). The planner thread never came back from
    make_plan: the goal stayed ACTIVE with nothing logged after the first 'no valid
    command ... planning again', and the control loop, sharing the interpreter with it,
    ran 0.13 s cycles instead of 0.05 s. Here the start 7 cells deep in a 100 x 100
    forbidden block: the region it opens (as the plain breadth-first search's) in
    milliseconds (0.5 s allowed)."""
    import time
    from my_summit_path_planning.navfn import start_region
    forbidden = np.zeros((120, 120), bool)
    forbidden[10:110, 10:110] = True
    lethal = np.zeros_like(forbidden)
    t0 = time.perf_counter()
    region = start_region(forbidden, lethal, (60, 17))
    took = time.perf_counter() - t0
    npt.assert_array_equal(region, start_region_reference(forbidden, lethal, (60, 17)))
    assert region.sum() == 264       # 7 cells from the edge, 14 steps: the block's rim up to depth 7
    assert took < 0.5, f"start_region took {took:.1f} s at depth 7"
