"""The planners' compiled kernels (summit_nav_common/csrc: global_planner.c, trajectory.c,
footprint_cost.c) equal their Python twins (the kernels' Python bodies in
global_planner.py, trajectory_planner.py and footprint_cost.py, run as plain Python) to the
bit, on random grids and on the edges: heap and path buffers that must grow, grids of one
row or column, seeds and targets repeated, potentials reached up to the border
(outline_map false), failures on the first and on the last point.

And move_base loads no numba (LLVM, ~60 MB) in any configuration: importing each planner
module and building each registered planner leaves 'numba' out of sys.modules (checked in
a fresh interpreter, as move_base starts).
"""
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning import footprint_cost as fc
from my_summit_path_planning import global_planner as gp
from my_summit_path_planning import trajectory_planner as tp
from my_summit_path_planning.global_plan import POT_HIGH


def assert_bits_equal(a, b):
    """Equal to the bit (NaN, -0.0 and all): the same dtype, shape and bytes."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), f"{np.count_nonzero(a != b)} values differ"


def random_cost(rng, ny, nx, forbidden=0.2):
    """Planner cell costs (flat): GlobalPlanner's costs of random costmap cells, some a
    fraction more (ties and non-ties), some forbidden (inf)."""
    data = rng.integers(0, 256, size=(ny, nx)).astype(np.uint8)
    cost = gp.planner_costs(data, 253, int(rng.integers(1, 80)), float(rng.uniform(0.01, 5.0)))
    cost += np.where(rng.random(cost.shape) < 0.5, rng.uniform(0, 1, cost.shape), 0.0)
    cost[rng.random(cost.shape) < forbidden] = np.inf
    return cost.ravel()


def expand_both(cost, nx, ny, seeds, seed_pots, goal, heuristic, quadratic):
    out = []
    for fn in (gp.expand, gp._expand):
        pot = np.full(nx * ny, POT_HIGH)
        reached, accepted = fn(cost, nx, ny, seeds, seed_pots, goal, heuristic, quadratic, pot)
        out.append((bool(reached), int(accepted), pot))
    (r1, a1, p1), (r2, a2, p2) = out
    assert (r1, a1) == (r2, a2)
    assert_bits_equal(p1, p2)
    return p1, r1


# ----- GlobalPlanner ----------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(12))
def test_expand_equals_python(seed):
    rng = np.random.default_rng(seed)
    ny, nx = (int(v) for v in rng.integers(1, 40, 2))
    if seed < 2:
        ny = 1  # one row, then one column
        nx, ny = (nx, ny) if seed == 0 else (ny, nx)
    cost = random_cost(rng, ny, nx)
    k = int(rng.integers(1, 5))
    seeds = rng.integers(0, nx * ny, k).astype(np.int64)
    seeds[-1] = seeds[0]  # a repeated seed: the lower potential wins
    seed_pots = rng.uniform(0, 100, k)
    goals = [-1, int(rng.integers(0, nx * ny)), int(seeds[0])]
    for goal in goals:
        for heuristic in (0.0, gp.HEURISTIC_WEIGHT * 50):
            for quadratic in (True, False):
                expand_both(cost, nx, ny, seeds, seed_pots, goal, heuristic, quadratic)


def test_expand_heap_grows():
    """More seeds than the heap's first capacity: the heap doubles (twice)."""
    rng = np.random.default_rng(7)
    ny, nx = 230, 250
    cost = random_cost(rng, ny, nx, forbidden=0.05)
    seeds = rng.permutation(nx * ny)[:5 * gp.HEAP_CAPACITY // 2].astype(np.int64)
    pot, _ = expand_both(cost, nx, ny, seeds, rng.uniform(0, 1e4, len(seeds)), -1, 0.0, True)
    assert (pot < POT_HIGH).sum() > len(seeds)


@pytest.mark.parametrize("seed", range(8))
def test_clear_endpoint_equals_python(seed):
    rng = np.random.default_rng(100 + seed)
    ny, nx = (int(v) for v in rng.integers(1, 25, 2))
    cost = random_cost(rng, ny, nx)
    base = np.where(rng.random(nx * ny) < 0.5, POT_HIGH, rng.uniform(0, 500, nx * ny))
    for _ in range(6):
        gx, gy = int(rng.integers(-3, nx + 3)), int(rng.integers(-3, ny + 3))
        for half in (0, 2, 5):
            for quadratic in (True, False):
                a, b = base.copy(), base.copy()
                gp.clear_endpoint(cost, nx, ny, a, gx, gy, half, quadratic)
                gp._clear_endpoint(cost, nx, ny, b, gx, gy, half, quadratic)
                assert_bits_equal(a, b)


def planner_potential(rng, ny, nx, outline, forbidden=0.15):
    """A potential as make_plan leaves it: expanded from a random passable cell (every
    reachable cell), border cells forbidden when outline; and that cell."""
    cost = random_cost(rng, ny, nx, forbidden).reshape(ny, nx)
    if outline:
        cost[0, :] = cost[-1, :] = cost[:, 0] = cost[:, -1] = np.inf
    free = np.flatnonzero(np.isfinite(cost))
    s = int(free[rng.integers(len(free))])
    pot = np.full(nx * ny, POT_HIGH)
    gp.expand(cost.ravel(), nx, ny, np.array([s], np.int64), np.zeros(1), -1, 0.0, True, pot)
    return pot, (s % nx, s // nx)


def paths_equal(c_result, py_result):
    (c_pts, c_ok), (py_pts, py_ok) = c_result, py_result
    assert bool(c_ok) == bool(py_ok)
    assert_bits_equal(c_pts, np.ascontiguousarray(py_pts))
    return c_pts, c_ok


@pytest.mark.parametrize("seed", range(10))
@pytest.mark.parametrize("outline", [True, False])
def test_path_makers_equal_python(seed, outline):
    """Both path makers from random reached (and unreached) cells down to the start, on
    potentials reached up to the border when the outline is not forbidden; sub-cell starts
    and goals; short and long cycle limits. The more open grids take long gradient
    steps: there the oracle's hypot must be libm's (math.hypot's rounding differs)."""
    rng = np.random.default_rng(200 + seed)
    ny, nx = (int(v) for v in rng.integers(3, 45, 2))
    pot, (sx, sy) = planner_potential(rng, ny, nx, outline, forbidden=(0.15, 0.02, 0.0)[seed % 3])
    reached = np.flatnonzero(pot < POT_HIGH)
    for _ in range(8):
        g = int(reached[rng.integers(len(reached))]) if rng.random() < 0.8 else int(rng.integers(nx * ny))
        gx, gy = g % nx, g // nx
        for max_cycles in (0, 3, 4 * nx * ny):
            fsx, fsy = sx + rng.uniform(-0.5, 0.5), sy + rng.uniform(-0.5, 0.5)
            fgx, fgy = gx + rng.uniform(-0.5, 0.5), gy + rng.uniform(-0.5, 0.5)
            paths_equal(gp.gradient_path(pot, nx, ny, fsx, fsy, fgx, fgy, gp.PATH_STEP, max_cycles),
                        gp._gradient_path(pot, nx, ny, fsx, fsy, fgx, fgy, gp.PATH_STEP, max_cycles))
            paths_equal(gp.grid_path(pot, nx, ny, sx, sy, gx, gy, max_cycles),
                        gp._grid_path(pot, nx, ny, sx, sy, gx, gy, max_cycles))


def test_long_paths_grow_their_buffers():
    """A 400-cell corridor: both paths longer than the first 256-point buffer."""
    nx, ny = 404, 5
    cost = np.full((ny, nx), np.inf)
    cost[1:4, 1:-1] = 50.0
    pot = np.full(nx * ny, POT_HIGH)
    gp.expand(cost.ravel(), nx, ny, np.array([2 * nx + 1], np.int64), np.zeros(1), -1, 0.0, True, pot)
    pts, ok = paths_equal(gp.gradient_path(pot, nx, ny, 1.0, 2.0, 401.2, 2.1, gp.PATH_STEP, 4 * nx * ny),
                          gp._gradient_path(pot, nx, ny, 1.0, 2.0, 401.2, 2.1, gp.PATH_STEP, 4 * nx * ny))
    assert ok and len(pts) > 600
    pts, ok = paths_equal(gp.grid_path(pot, nx, ny, 1, 2, 401, 3, 4 * nx * ny),
                          gp._grid_path(pot, nx, ny, 1, 2, 401, 3, 4 * nx * ny))
    assert ok and len(pts) > 256


def test_gradient_near_the_border_reads_only_the_grid():
    """Without outline_map a reached border cell's gradient has no neighbour off the grid
    (the compiled kernel read one there: the row before the grid's first, after its last)."""
    nx, ny = 6, 6
    pot = np.arange(nx * ny, dtype=np.float64) * 10.0
    pot[0] = -50.0   # what cell 0's wrapped 'left neighbour' (the last cell) would not see
    for n in (0, nx - 1, nx * (ny - 1), nx * ny - 1):
        g = gp._grad(pot, nx, ny, n)
        assert np.all(np.isfinite(g)) and abs(np.hypot(*g) - 1.0) < 1e-12
    pts, ok = paths_equal(gp.gradient_path(pot, nx, ny, 0.0, 0.0, 4.4, 4.3, gp.PATH_STEP, 200),
                          gp._gradient_path(pot, nx, ny, 0.0, 0.0, 4.4, 4.3, gp.PATH_STEP, 200))
    assert len(pts) > 1


@pytest.mark.parametrize("use_dijkstra", [True, False])
@pytest.mark.parametrize("flags", [{}, {"use_grid_path": True}, {"old_navfn_behavior": True},
                                   {"outline_map": False, "use_quadratic": False}])
def test_make_plan_equals_python_kernels(monkeypatch, footprint, make_static_costmap, use_dijkstra, flags):
    """Whole plans on a walled map, compiled kernels vs the Python ones: the same path,
    potential and cells expanded, to the bit."""
    occ = np.zeros((48, 64), np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    occ[10:40, 20] = occ[8:30, 40] = 100
    cm = make_static_costmap(occ, footprint, resolution=0.1).master
    cfg = gp.GlobalPlannerConfig(use_dijkstra=use_dijkstra, **flags)
    results = []
    for python in (False, True):
        if python:
            for name in ("expand", "clear_endpoint", "gradient_path", "grid_path"):
                monkeypatch.setattr(gp, name, getattr(gp, "_" + name))
        planner = gp.GlobalPlanner(cfg)
        r = planner.make_plan(cm, (1.03, 1.07, 0.2), (5.71, 3.62, -1.0))
        results.append((r, planner.cells_expanded))
    (a, na), (b, nb) = results
    assert a.path is not None and len(a.path) > 20
    assert na == nb
    assert_bits_equal(a.path, b.path)
    assert_bits_equal(a.yaws, b.yaws)
    assert_bits_equal(a.potential, b.potential)


# ----- footprint cost and TrajectoryPlannerROS -----------------------------------------------------

def random_data(rng, h, w):
    data = rng.integers(0, 253, size=(h, w)).astype(np.uint8)
    data[rng.random((h, w)) < 0.01] = cv.LETHAL_OBSTACLE
    data[rng.random((h, w)) < 0.01] = cv.NO_INFORMATION
    return data


@pytest.mark.parametrize("seed", range(6))
def test_outline_costs_equal_python(seed):
    rng = np.random.default_rng(300 + seed)
    h, w = (int(v) for v in rng.integers(1, 60, 2))
    data = random_data(rng, h, w)
    m, k = 300, int(rng.integers(1, 9))
    vx, vy = rng.integers(0, w, (m, k)), rng.integers(0, h, (m, k))
    vx[:5], vy[:5] = vx[:5, :1], vy[:5, :1]           # every vertex in one cell
    on_map = rng.random(m) < 0.8
    assert_bits_equal(fc.outline_costs(data, vx, vy, on_map), fc._outline_costs(data, vx, vy, on_map))


@pytest.mark.parametrize("seed", range(8))
def test_wavefront_equals_python(seed):
    rng = np.random.default_rng(400 + seed)
    h, w = (int(v) for v in rng.integers(1, 50, 2))
    blocked = rng.random((h, w)) < rng.uniform(0, 0.4)
    n = int(rng.integers(0, 6))
    tx, ty = rng.integers(0, w, n), rng.integers(0, h, n)
    if n > 1:
        tx[1], ty[1] = tx[0], ty[0]  # a repeated target
    obstacle = float(h * w)
    assert_bits_equal(tp.wavefront(blocked, tx, ty, obstacle), tp._wavefront(blocked, tx, ty, obstacle))


def test_wavefront_refuses_targets_off_the_grid():
    with pytest.raises(ValueError, match="off the 4 x 3 grid"):
        tp.wavefront(np.zeros((3, 4), bool), np.array([4]), np.array([0]), 12.0)


@pytest.mark.parametrize("seed", range(8))
def test_first_failure_equals_python(seed):
    rng = np.random.default_rng(500 + seed)
    h, w = (int(v) for v in rng.integers(2, 50, 2))
    data = random_data(rng, h, w)
    n_traj, s, k = int(rng.integers(1, 30)), int(rng.integers(1, 25)), int(rng.integers(1, 6))
    n = rng.integers(1, s + 1, n_traj)
    n[0] = s
    on_map = rng.random((n_traj, s)) < 0.97
    vx, vy = rng.integers(0, w, (n_traj, s, k)), rng.integers(0, h, (n_traj, s, k))
    no_way = rng.random((n_traj, s)) < 0.03
    no_way[-1, n[-1] - 1] = True                      # a failure on a trajectory's last point
    centre = data[rng.integers(0, h, (n_traj, s)), rng.integers(0, w, (n_traj, s))].astype(np.float64)
    got = tp.first_failure(data, n, on_map, vx, vy, no_way, centre)
    want = tp._first_failure(data, n, on_map, vx, vy, no_way, centre)
    for a, b in zip(got, want):
        assert_bits_equal(a, b)


# ----- no numba in move_base --------------------------------------------------------------------

def run_fresh(code):
    """Run code in a fresh interpreter (move_base's imports), raising on failure."""
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


@pytest.mark.parametrize("module", ["trajectory_planner", "global_planner", "footprint_cost", "carrot_planner",
                                    "navfn", "dwa", "plugins", "layers", "move_base_core", "ros.costmap_ros",
                                    "ros.sensor_hub", "ros.reconfigure"])
def test_planner_modules_import_no_numba(module):
    run_fresh(f"""
        import sys
        import my_summit_path_planning.{module}
        assert 'numba' not in sys.modules, 'importing {module} imported numba'
    """)


def test_every_registered_planner_is_built_without_numba():
    """Each base_global_planner and base_local_planner type move_base can be given, built as
    move_base builds it (the registry's factory), planning once on a small costmap."""
    out = run_fresh("""
        import sys
        import numpy as np
        from my_summit_path_planning import plugins
        from my_summit_path_planning.costmap import Costmap2D, Footprint
        from my_summit_path_planning.nav_core import PluginContext
        fp = Footprint.from_params([[0.36, 0.31], [-0.36, 0.31], [-0.36, -0.31], [0.36, -0.31]])
        ctx = PluginContext(footprint=fp, controller_frequency=20.0)
        cm = Costmap2D(80, 80, 0.05, -2.0, -2.0)
        built = []
        for registry in (plugins.GLOBAL_PLANNERS, plugins.LOCAL_PLANNERS):
            for name in registry.known():
                planner = registry.create(name, {}, ctx, name.split('/')[-1])
                if registry is plugins.GLOBAL_PLANNERS:
                    assert planner.make_plan(cm, (0.0, 0.0, 0.0), (1.0, 0.5, 0.0)).path is not None, name
                else:
                    planner.set_plan(np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]), 0.0)
                    planner.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), cm)
                built.append(name)
        assert 'numba' not in sys.modules, 'numba imported'
        print(','.join(built))
    """)
    built = set(out.split()[-1].split(","))
    assert {"navfn/NavfnROS", "global_planner/GlobalPlanner", "carrot_planner/CarrotPlanner",
            "dwa_local_planner/DWAPlannerROS", "base_local_planner/TrajectoryPlannerROS"} <= built
