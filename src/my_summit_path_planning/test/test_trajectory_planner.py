"""base_local_planner's TrajectoryPlannerROS (trajectory_planner.py) on hand-built costmaps.

- The vectorized parts equal their slow references: Bresenham lines, the footprint
  outline cost, the MapGrid wavefront, every rollout's cost and points, and the whole
  planner's commands over a short drive.
- Scoring: in a corridor the command drives along the plan; with an obstacle ahead the
  robot turns away; one trajectory's cost terms against hand-computed values, in cells
  and with meter_scoring.
- The goal: braking first, then rotating in place at the real planner's rate, reached
  within yaw_goal_tolerance. Boxed in, the robot backs up at escape_vel in escape mode.
- Parameters: deprecated names map to the current ones with the real node's warnings;
  wrong types name where/key and the expected type.
"""
import math

import numpy as np
import numpy.testing as npt
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning import footprint_cost as fc
from my_summit_path_planning import trajectory_planner as tp
from my_summit_path_planning.costmap import Costmap2D, Footprint
from my_summit_path_planning.param_reader import UNREAD
from my_summit_path_planning.params import ParamError

RES = 0.05  # [m/cell]
SUMMIT = [[0.36, 0.31], [-0.36, 0.31], [-0.36, -0.31], [0.36, -0.31]]


@pytest.fixture
def fp():
    return Footprint.from_params(SUMMIT, padding=0.01)


def _costmap(size=140, origin=(-3.5, -3.5)):
    return Costmap2D(size, size, RES, *origin)


def _box(m, x0, y0, x1, y1, cost=cv.LETHAL_OBSTACLE):
    a, b = m.world_to_map_no_bounds(x0, y0), m.world_to_map_no_bounds(x1, y1)
    m.data[max(0, a[1]):b[1] + 1, max(0, a[0]):b[0] + 1] = cost


def _cluttered(seed):
    """A 7 m costmap with random lethal blocks, unknown patches and graded costs."""
    rng = np.random.default_rng(seed)
    m = _costmap()
    m.data[:] = rng.integers(0, 120, m.data.shape).astype(np.uint8)
    for _ in range(25):
        x, y = rng.uniform(-3.5, 3.5, 2)
        if math.hypot(x, y) < 0.9:
            continue
        _box(m, x, y, x + rng.uniform(0.05, 0.4), y + rng.uniform(0.05, 0.4),
             rng.choice([cv.LETHAL_OBSTACLE, cv.INSCRIBED_INFLATED_OBSTACLE, cv.NO_INFORMATION]))
    _box(m, 0.8, -0.2, 1.0, 0.5)                            # near the robot, whatever the seed
    _box(m, -0.9, 0.5, -0.7, 0.8, cv.NO_INFORMATION)
    _box(m, 0.1, -1.0, 0.3, -0.8, cv.INSCRIBED_INFLATED_OBSTACLE)
    return m


def _planner(fp, reference=False, **params):
    return tp.TrajectoryPlanner(tp.trajectory_planner_config(params)[0], fp, reference=reference)


# -- fast equals reference -------------------------------------------------------------------
def test_bresenham_equals_the_iterator():
    rng = np.random.default_rng(0)
    ends = rng.integers(-20, 20, size=(300, 4))
    ends[:5] = [[0, 0, 0, 0], [3, 3, 3, 3], [0, 0, 7, 0], [0, 0, 0, -7], [0, 0, 5, 5]]
    xs, ys, valid = fc.bresenham(*ends.T)
    for k, (x0, y0, x1, y1) in enumerate(ends):
        got = list(zip(xs[k][valid[k]].tolist(), ys[k][valid[k]].tolist()))
        assert got == fc.line_cells_reference(x0, y0, x1, y1)
        assert got[0] == (x0, y0) and got[-1] == (x1, y1)


@pytest.mark.parametrize("seed", range(3))
def test_footprint_costs_equal_reference(fp, seed):
    m = _cluttered(seed)
    rng = np.random.default_rng(10 + seed)
    poses = np.column_stack([rng.uniform(-3.8, 3.8, 400), rng.uniform(-3.8, 3.8, 400), rng.uniform(-4, 4, 400)])
    fast = fc.footprint_costs(m, fp.polygon, poses[:, 0], poses[:, 1], poses[:, 2])
    ref = [fc.footprint_cost_reference(m, fp.polygon, *p) for p in poses]
    npt.assert_array_equal(fast, ref)
    assert {fc.OFF_MAP, fc.COLLIDES} <= set(fast.tolist())  # both failures occur
    assert (fast >= 0).sum() > 20


@pytest.mark.parametrize("seed", range(3))
def test_map_grid_equals_queue_wavefront(fp, seed):
    m = _cluttered(seed)
    within = tp.footprint_cells(m, fp.polygon, (0.0, 0.0, 0.3))
    plan = np.column_stack([np.linspace(-0.2, 3.3, 50), 1.5 * np.sin(np.linspace(0, 3, 50))])
    targets = tp.plan_cells(m, plan)
    fast = tp.map_grid(m, targets, within)
    ref = tp.map_grid_reference(m, targets, within)
    npt.assert_array_equal(fast, ref)
    obstacle = float(m.data.size)
    assert (fast == obstacle).any() and (fast == obstacle + 1).any() and (fast == 0).any()



@pytest.mark.parametrize("seed", range(3))
def test_footprint_cells_equal_reference(fp, seed):
    """The filled footprint, at random poses including ones half off the costmap."""
    m = _costmap(size=60, origin=(-1.5, -1.5))
    rng = np.random.default_rng(20 + seed)
    for pose in np.column_stack([rng.uniform(-1.9, 1.9, 60), rng.uniform(-1.9, 1.9, 60), rng.uniform(-4, 4, 60)]):
        npt.assert_array_equal(tp.footprint_cells(m, fp.polygon, pose), tp.footprint_cells_reference(m, fp.polygon, pose))


def test_densify_equals_reference():
    """Points added between plan points further apart than the resolution, bit for bit."""
    rng = np.random.default_rng(3)
    for n in (0, 1, 2, 7, 60):
        plan = np.cumsum(rng.uniform(-0.2, 0.2, (n, 2)), axis=0)
        if n > 3:
            plan[2] = plan[1]                # a repeated point
            plan[3] = plan[2] + [0.05, 0.0]  # exactly one resolution apart
        fast, ref = tp.densify(plan, RES), tp.densify_reference(plan, RES)
        assert fast.shape == ref.shape
        npt.assert_array_equal(fast, ref)
        if n > 1:
            assert np.hypot(*np.diff(fast, axis=0).T).max() <= RES + 1e-12

def test_map_grid_counts_cells_round_a_wall(fp):
    """4-connected cells; an obstacle holds obstacle_cost, a walled-off cell one more."""
    m = Costmap2D(10, 6, RES)
    m.data[0:5, 5] = cv.LETHAL_OBSTACLE          # wall at mx = 5 from my = 0 to 4
    d = tp.map_grid(m, (np.array([2]), np.array([0])), np.zeros(m.data.shape, bool))
    assert d[0, 2] == 0 and d[0, 0] == 2 and d[3, 2] == 3
    assert d[0, 6] == 5 + 4 + 5                 # up to my 5, across mx 2 -> 6, down again
    assert d[2, 5] == 60.0                        # in the wall, touched: obstacle cost
    m.data[5, 5] = cv.INSCRIBED_INFLATED_OBSTACLE  # close the gap: the far side is unreachable
    d = tp.map_grid(m, (np.array([2]), np.array([0])), np.zeros(m.data.shape, bool))
    assert d[0, 7] == 61.0 and d[5, 5] == 60.0


CASES = [dict(), dict(dwa=True), dict(heading_scoring=True, heading_scoring_timestep=0.3),
         dict(simple_attractor=True), dict(meter_scoring=True, sim_time=1.7, angular_sim_granularity=0.1)]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_rollouts_equal_reference(fp, case):
    cfg = tp.trajectory_planner_config(CASES[case])[0]
    rng = np.random.default_rng(case)
    m = _cluttered(case)
    plan = np.column_stack([np.linspace(0.0, 3.3, 60), 0.8 * np.sin(np.linspace(0, 2, 60))])
    pose = (0.0, 0.0, 0.2)
    grids = tp.map_grids(m, plan, fp.polygon, pose)
    samples = np.column_stack([rng.uniform(-0.3, 0.8, 120), rng.choice([0.0, 0.0, 0.1, -0.3], 120),
                               rng.uniform(-1.5, 1.5, 120)])
    samples[:3] = [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.0, 0.4]]
    vel = (0.2, 0.05, -0.3)
    biases = (0.6 * (RES if cfg.meter_scoring else 1), 0.8 * (RES if cfg.meter_scoring else 1))
    fast = tp.rollout(cfg, pose, vel, samples, m, grids, fp.polygon, biases)
    ref = tp.rollout_reference(cfg, pose, vel, samples, m, grids, fp.polygon, biases)
    npt.assert_allclose(fast.cost, ref.cost, rtol=1e-12, atol=1e-12)
    legal = fast.cost >= 0
    assert 10 < legal.sum() < len(samples)  # legal and illegal ones both checked
    for i in np.flatnonzero(legal):
        npt.assert_allclose(fast.points(i), ref.points(i), rtol=0, atol=1e-12)


@pytest.mark.parametrize("dwa", [False, True])
def test_planner_commands_equal_reference(fp, dwa):
    """The planner on the fast parts and on the references: the same commands over a drive."""
    m = _costmap()
    _box(m, 1.0, -0.2, 1.3, 0.4)
    _box(m, -3.5, 1.2, 3.5, 1.3)
    plan = np.column_stack([np.linspace(0.0, 3.0, 61), -0.7 * np.sin(np.linspace(0, math.pi, 61))])
    planners = [_planner(fp, ref, dwa=dwa) for ref in (False, True)]
    for p in planners:
        p.set_plan(plan, 0.0)
    pose, vel = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    for _ in range(12):
        fast, ref = (p.compute_velocity(pose, vel, m) for p in planners)
        assert fast.cmd == ref.cmd and fast.ok == ref.ok and fast.mode == ref.mode
        npt.assert_allclose(fast.cost, ref.cost, rtol=1e-12)
        vel = fast.cmd
        pose = (pose[0] + 0.1 * vel[0] * math.cos(pose[2]), pose[1] + 0.1 * vel[0] * math.sin(pose[2]),
                pose[2] + 0.1 * vel[2])


# -- scoring ------------------------------------------------------------------------------------
def test_corridor_drives_along_the_plan(fp):
    m = _costmap()
    _box(m, -3.5, -0.9, 3.5, -0.8)
    _box(m, -3.5, 0.8, 3.5, 0.9)
    p = _planner(fp, holonomic_robot=False, dwa=False)   # Trajectory Rollout
    p.set_plan(np.column_stack([np.linspace(0.0, 3.4, 69), np.zeros(69)]), 0.0)
    r = p.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert r.ok and r.mode == "rollout"
    assert r.cmd == pytest.approx((0.5, 0.0, 0.0))  # the fastest straight sample: nearest the goal
    npt.assert_allclose(r.trajectory[:, 1], 0.0, atol=1e-12)


def test_obstacle_ahead_turns_away(fp):
    """A block on the robot's line, the plan bending left round it: the robot turns left."""
    m = _costmap()
    _box(m, 0.7, -0.6, 1.0, 0.15)
    p = _planner(fp, holonomic_robot=False, sim_time=1.7, dwa=False)   # Trajectory Rollout
    s = np.linspace(0.0, 1.0, 41)
    plan = np.vstack([np.column_stack([0.4 * s, 0.8 * s ** 2]),
                      np.column_stack([np.linspace(0.4, 3.0, 53), np.full(53, 0.8)])])
    p.set_plan(plan, 0.0)
    r = p.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert r.ok and r.cmd[2] > 0.3, r
    straight = tp.rollout(p.config, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), np.array([[0.5, 0.0, 0.0]]), m,
                          p.grids, fp.polygon, (0.6, 0.8))
    assert straight.cost[0] < 0 or straight.cost[0] > r.cost


def test_only_the_path_wave_crosses_the_robot(fp):
    """findBestPath marks the cells under the footprint within_robot in path_map_ alone: an
    inscribed cell under the robot stops the goal wave, so a trajectory whose centre
    crosses it has no way to the goal (cost -2), and with the centre on it nothing is legal."""
    m = _costmap()
    _box(m, 0.2, 0.0, 0.2, 0.0, cost=cv.INSCRIBED_INFLATED_OBSTACLE)   # cell (74, 70), under the front
    p = _planner(fp, holonomic_robot=False, dwa=False)
    p.set_plan(np.column_stack([np.linspace(-0.5, 3.4, 79), np.zeros(79)]), 0.0)
    assert p.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m).ok   # a curve round the cell
    obstacle = float(m.data.size)
    assert p.grids.path[70, 74] == 0.0              # on the plan, and the path wave crosses the robot
    assert p.grids.goal[70, 74] == obstacle          # the goal wave does not
    assert p.grids.goal[70, 75] < obstacle           # the far side reached round the cell
    straight = tp.rollout(p.config, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), np.array([[0.3, 0.0, 0.0]]), m,
                          p.grids, fp.polygon, p._biases(m))
    assert straight.x[0, :straight.n[0]].max() > 0.2   # the centre passes x 0.2 .. 0.25
    assert straight.cost[0] == tp.NO_WAY
    r = p.compute_velocity((0.21, 0.01, 0.0), (0.0, 0.0, 0.0), m)   # centre on the cell
    assert not r.ok and r.mode == "escape" and r.n_valid == 0


def _open_map():
    """4 m x 2 m, origin (-1, -1): the hand-computed scoring case."""
    return Costmap2D(80, 40, RES, -1.0, -1.0)


@pytest.mark.parametrize("meter_scoring", [False, True])
def test_cost_terms_by_hand(fp, meter_scoring):
    m = _open_map()
    m.data[:] = 0
    _box(m, 0.45, -0.6, 0.6, 0.6, cost=100)   # graded cost under the front of the outline at the end
    p = _planner(fp, meter_scoring=meter_scoring)
    plan = np.column_stack([np.linspace(-0.5, 1.975, 100), np.full(100, 0.175)])  # 3 cells left of the robot
    p.set_plan(plan, 0.0)
    p.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    r = tp.rollout(p.config, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), np.array([[0.3, 0.0, 0.0]]), m, p.grids,
                   fp.polygon, p._biases(m))
    # 12 steps of 1/12 s; the speed ramps 0 -> 0.2083 (2.5 m/s^2 x 1/12 s) -> 0.3 m/s; the
    # last scored point is after 11 moves: x = (0.2083 + 10 x 0.3) / 12 = 0.2674 m, cell 25.
    assert r.n[0] == 12
    npt.assert_allclose(r.x[0, 11], (2.5 / 12 + 10 * 0.3) / 12, rtol=1e-12)
    path_cells, goal_cells = 3, (59 - 25) + 3      # plan at row 23 (y 0.175), robot row 20
    occ = 100                                      # outline front at x 0.2674 + 0.37 = 0.637 m
    scale = RES if meter_scoring else 1.0
    expected = 0.6 * scale * path_cells + 0.8 * scale * goal_cells + 0.01 * occ
    npt.assert_allclose(r.cost[0], expected, rtol=1e-12)
    assert p.grids.path[20, 25] == path_cells and p.grids.goal[20, 25] == goal_cells


# -- the goal ---------------------------------------------------------------------------------------
def test_goal_brake_then_rotate_in_place_then_reached(fp):
    m = _costmap()
    p = _planner(fp)
    p.set_plan(np.column_stack([np.linspace(-1.0, 0.0, 21), np.zeros(21)]), 1.0)
    r = p.compute_velocity((0.05, 0.0, 0.0), (0.3, 0.0, 0.2), m)  # within 0.1 m, still moving
    assert r.ok and r.mode == "stop"
    npt.assert_allclose(r.cmd, (0.3 - 2.5 * 0.05, 0.0, max(0.0, 0.2 - 3.2 * 0.05)))
    r = p.compute_velocity((0.05, 0.0, 0.0), (0.0, 0.0, 0.0), m)  # stopped: rotate
    assert r.ok and r.mode == "rotate"
    # min(max_vel_theta, max(0.4, err 1.0)) = 1.0, within 0 +- 3.2 x 0.05 -> 0.16, then min 0.4
    assert r.cmd == (0.0, 0.0, 0.4)
    r = p.compute_velocity((0.05, 0.0, 0.9), (0.0, 0.0, 0.4), m)
    # err 0.1: max(0.4, 0.1) = 0.4 within [0.24, 0.56]; sqrt(2 x 3.2 x 0.1) = 0.8 -> 0.4
    assert r.cmd == (0.0, 0.0, 0.4) and not p.is_goal_reached()
    r = p.compute_velocity((0.05, 0.0, 0.97), (0.0, 0.0, 0.4), m)
    assert r.goal_reached and p.is_goal_reached() and r.mode == "goal"


def test_goal_latch_keeps_rotating_outside_tolerance(fp):
    m = _costmap()
    p = _planner(fp, latch_xy_goal_tolerance=True)
    p.set_plan(np.column_stack([np.linspace(-1.0, 0.0, 21), np.zeros(21)]), -1.0)
    assert p.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m).mode == "rotate"
    r = p.compute_velocity((0.15, 0.0, 0.0), (0.0, 0.0, 0.0), m)   # 0.15 m off: latched, still rotating
    assert r.mode == "rotate" and r.cmd[2] < 0
    p.set_plan(np.column_stack([np.linspace(-1.0, 0.0, 21), np.zeros(21)]), -1.0)  # a new plan unlatches
    assert p.compute_velocity((0.15, 0.0, 0.0), (0.0, 0.0, 0.0), m).mode != "rotate"


# -- escape ---------------------------------------------------------------------------------------------
def test_boxed_in_backs_up_in_escape_mode(fp):
    """Nose 3 cm from a wall, walls 3 cm off both sides: no forward motion, turn or strafe
    is legal; the robot backs up at escape_vel until escape_reset_dist, then plans again."""
    m = _costmap()
    _box(m, 0.40, -1.0, 0.5, 1.0)     # wall ahead (front at 0.37)
    _box(m, -1.5, 0.35, 0.5, 0.45)    # left wall (side at 0.32)
    _box(m, -1.5, -0.45, 0.5, -0.36)  # right wall (cells to y -0.35)
    p = _planner(fp)
    plan = np.vstack([np.column_stack([np.linspace(0.0, -2.0, 41), np.zeros(41)]),
                      np.column_stack([np.full(30, -2.0), np.linspace(0.05, 1.5, 30)]),
                      np.column_stack([np.linspace(-1.95, 1.5, 70), np.full(70, 1.5)])])
    p.set_plan(plan, 0.0)
    pose = (0.0, 0.0, 0.0)
    r = p.compute_velocity(pose, (0.0, 0.0, 0.0), m)
    assert r.ok and r.mode == "escape" and r.cmd == (-0.1, 0.0, 0.0) and r.n_valid == 0
    assert p.escaping
    n_forward = r.n_samples
    for _ in range(30):          # 2 cm back at a time: forward samples are not tried meanwhile
        pose = (pose[0] - 0.02, pose[1], pose[2])
        r = p.compute_velocity(pose, (-0.1, 0.0, 0.0), m)
        if not p.escaping:
            break
        assert r.n_samples < n_forward
    assert not p.escaping and -0.2 < pose[0] <= -0.1


def _line(m, x0, y0, x1, y1):
    """Lethal cells along the segment (x0, y0) - (x1, y1) [m], a quarter cell apart."""
    n = int(math.hypot(x1 - x0, y1 - y0) / (0.25 * RES)) + 1
    for x, y in zip(np.linspace(x0, x1, n), np.linspace(y0, y1, n)):
        c = m.world_to_map(x, y)
        m.data[c[1], c[0]] = cv.LETHAL_OBSTACLE


@pytest.mark.parametrize("walls", ["ahead", "ahead and along the side", "ahead and along the side at 2 degrees",
                                   "ahead and behind", "ahead and closing in on a rear corner",
                                   "ahead, pressed into the side and behind"])
def test_backs_up_off_a_touched_obstacle_but_not_onto_another(fp, walls):
    """The nose on a wall's cells (the outline touches them, so every sample fails, the
    backing one too): the robot backs up at escape_vel, as the real planner does, also
    with its side on a wall it slides along, straight or 2 degrees off. With a second wall
    4 cm behind its rear, or one that closes in on a rear corner, it does not: the real
    planner backs into it (its rule: back up even when the footprint hits something), ours
    reports no command instead.

    Regressions (planning bench, willow-full-0.05): pair 11, navfn + TrajectoryPlannerROS
    dwa: true: stuck between the walls of a doorway for 80 s, the robot backed at -0.1 m/s
    into the wall behind it (1 collision; astar pair 1 and dijkstra pair 16 the same).
    Pair 11, dijkstra + TrajectoryPlannerROS dwa: false, t = 31 s at (45.52, 31.77): a
    wall running 13 degrees off the robot's axis, a cell off its rear-left corner, was
    let through by the first rule (a lethal cell behind the rear edge, more than a cell
    in from either side) and the corner backed into it (1 collision)."""
    m = _costmap()
    _box(m, 0.36, -1.0, 0.5, 1.0)                  # wall ahead, on the front edge's cells
    if walls == "ahead and behind":
        _box(m, -0.55, -1.0, -0.40, 1.0)           # rear edge at -0.36: 4 cm of room
    if walls == "ahead and along the side":
        _box(m, -1.5, 0.31, 0.5, 0.45)             # on the left edge's cells, all along
    if walls == "ahead and along the side at 2 degrees":
        _line(m, 0.35, 0.33, -1.5, 0.33 - 1.85 * math.tan(math.radians(2.0)))
    if walls == "ahead, pressed into the side and behind":   # a side wall 2 cells deep licenses no wall behind
        _box(m, -1.5, 0.22, 0.5, 0.45)
        _box(m, -0.55, -1.0, -0.40, 1.0)
    if walls == "ahead and closing in on a rear corner":
        _line(m, -0.3, 0.38, -1.5, 0.38 - 1.2 * math.tan(math.radians(13.0)))  # 5.5 cm off the corner
    p = _planner(fp)
    p.set_plan(np.column_stack([np.full(30, 0.0), np.linspace(0.0, 1.5, 30)]), 0.0)
    r = p.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert r.n_valid == 0 and r.mode == "escape"
    if walls in ("ahead and behind", "ahead and closing in on a rear corner", "ahead, pressed into the side and behind"):
        assert not r.ok and r.cmd == (0.0, 0.0, 0.0) and "would drive the rear onto an obstacle" in r.reason
        assert not p.escaping
    else:
        assert r.ok and r.cmd == (-0.1, 0.0, 0.0) and p.escaping


def test_polygon_signed_distance_equals_opencv():
    """The back-up's clearance measure against OpenCV's pointPolygonTest (positive outside
    there too once negated: OpenCV counts inside as positive)."""
    import cv2
    rng = np.random.default_rng(3)
    pts = rng.uniform(-0.8, 0.8, (500, 2))
    pts[:4] = [[0.0, 0.0], [0.36, 0.0], [0.5, 0.5], [-0.36, -0.31]]
    for poly in (np.array(SUMMIT), np.array([[0.4, 0.0], [0.0, 0.3], [-0.4, 0.1], [-0.2, -0.3]])):
        got = tp.polygon_signed_distance(poly, pts[:, 0], pts[:, 1])
        contour = poly.astype(np.float32).reshape(-1, 1, 2)
        want = [-cv2.pointPolygonTest(contour, (float(x), float(y)), True) for x, y in pts]
        npt.assert_allclose(got, want, atol=1e-5)
    assert tp.polygon_signed_distance(np.array(SUMMIT), 0.0, 0.0) == pytest.approx(-0.31)


def test_escape_mode_ends_on_a_cycle_that_refuses_the_back_up(fp):
    """Escape mode ends once the robot has moved escape_reset_dist from where it began,
    also on a cycle that refuses the back-up. The refusal of a back-up onto a wall behind
    first returned before that check, so a robot that had backed far enough and was then
    refused on every cycle stayed in escape mode (no forward samples) for good."""
    m = _costmap()
    _box(m, 0.36, -1.0, 0.5, 1.0)                  # wall ahead, on the front edge's cells
    _box(m, -0.55, -1.0, -0.40, 1.0)               # and 4 cm behind the rear edge
    p = _planner(fp)
    p.set_plan(np.column_stack([np.full(30, 0.0), np.linspace(0.0, 1.5, 30)]), 0.0)
    p.escaping, p.escape_pose = True, (0.3, 0.0, 0.0)   # backed 0.3 m since escape began
    r = p.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert not r.ok and "would drive the rear onto an obstacle" in r.reason
    assert not p.escaping


def test_no_way_to_the_plan_fails(fp):
    """The robot walled in all round with the plan outside: no command, not even backing up."""
    m = _costmap()
    for x0, y0, x1, y1 in ((-1, 1, 1, 1.1), (-1, -1.1, 1, -1), (1, -1, 1.1, 1), (-1.1, -1, -1, 1)):
        _box(m, x0, y0, x1, y1)
    p = _planner(fp, prune_plan=False)
    p.set_plan(np.column_stack([np.linspace(0.0, 0.9, 10), np.full(10, 1.8)]), 0.0)
    r = p.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert not r.ok and r.cmd == (0.0, 0.0, 0.0) and "no legal trajectory" in r.reason


# -- parameters -------------------------------------------------------------------------------------
def test_defaults_are_the_real_ones():
    cfg, notes = tp.trajectory_planner_config({})
    assert (cfg.acc_lim_x, cfg.acc_lim_theta, cfg.max_vel_x, cfg.min_vel_x, cfg.max_vel_theta, cfg.min_vel_theta,
            cfg.min_in_place_vel_theta, cfg.escape_vel, cfg.sim_time, cfg.vx_samples, cfg.vtheta_samples) == \
        (2.5, 3.2, 0.5, 0.1, 1.0, -1.0, 0.4, -0.1, 1.0, 3, 20)
    assert cfg.y_vels == (-0.3, -0.1, 0.1, 0.3) and cfg.holonomic_robot and cfg.dwa
    assert cfg.angular_granularity == cfg.sim_granularity == 0.025
    assert cfg.escape_reset_theta == pytest.approx(math.pi / 4) and cfg.sim_period == 0.05
    assert notes == [tp.METER_SCORING_UNSET]


def test_deprecated_names_map_and_warn(fp):
    p = tp.TrajectoryPlanner.from_params(
        {"acc_lim_th": 2.0, "max_rotational_vel": 0.8, "min_in_place_rotational_vel": 0.3, "backup_vel": -0.2,
         "pdist_scale": 0.7, "gdist_scale": 0.9, "path_distance_bias": 0.5, "meter_scoring": False,
         "acc_limit_x": 1.0, "y_vels": "[-0.3, -0.1, 0.1, -0.3]", "some_unknown": 1,
         "world_model": "costmap"}, fp, where="move_base/TrajectoryPlannerROS", controller_frequency=10.0)
    c = p.config
    assert (c.acc_lim_theta, c.max_vel_theta, c.min_vel_theta, c.min_in_place_vel_theta, c.escape_vel) == \
        (2.0, 0.8, -0.8, 0.3, -0.2)
    assert c.path_distance_bias == 0.5 and c.goal_distance_bias == 0.9  # the newer name wins
    assert c.y_vels == (-0.3, -0.1, 0.1, -0.3) and c.sim_period == pytest.approx(0.1)
    assert "Parameter acc_lim_th is deprecated. Please use the name acc_lim_theta instead." in p.notes
    assert "Parameter gdist_scale is deprecated. Please use the name goal_distance_bias instead." in p.notes
    assert not any("pdist_scale" in w for w in p.notes)
    assert tp.BACKUP_VEL_WARNING in p.notes and tp.METER_SCORING_FALSE in p.notes
    assert any(w.startswith("You are using acc_limit_x where you should be using acc_lim_x") for w in p.notes)
    assert [n.param for n in p.notes if n.kind == UNREAD] == ["some_unknown"]
    known = tp.TrajectoryPlanner.KNOWN_PARAMS
    assert {"acc_lim_th", "backup_vel", "world_model", "point_grid", "acc_limit_th"} <= known


def test_controller_frequency_in_the_namespace_wins():
    cfg, _ = tp.trajectory_planner_config({"controller_frequency": 5.0}, controller_frequency=10.0)
    assert cfg.sim_period == pytest.approx(0.2)
    cfg, warnings = tp.trajectory_planner_config({"controller_frequency": -1.0, "escape_vel": 0.1,
                                                     "vx_samples": 0})
    assert cfg.sim_period == 0.05 and cfg.vx_samples == 1
    assert any("controller_frequency less than 0" in w for w in warnings)
    assert any("positive escape velocity" in w for w in warnings)
    assert any("set vx_samples to 1" in w for w in warnings)


@pytest.mark.parametrize("key, value, expected", [
    ("max_vel_x", "fast", "float"), ("vx_samples", 2.5, "int"), ("dwa", 1, "bool"),
    ("holonomic_robot", "yes", "bool"),
    ("y_vels", [0.1, "a"], "list of floats"), ("gdist_scale", None, "float"), ("sim_time", 0.0, "> 0")])
def test_bad_values_name_where_and_key(fp, key, value, expected):
    with pytest.raises(ParamError) as e:
        tp.TrajectoryPlanner.from_params({key: value}, fp, where="move_base/TrajectoryPlannerROS")
    assert f"move_base/TrajectoryPlannerROS/{key}" in str(e.value) and expected in str(e.value)


def test_world_model_other_than_costmap_is_an_error(fp):
    with pytest.raises(ParamError, match="world_model"):
        tp.TrajectoryPlanner.from_params({"world_model": "freespace"}, fp)


# -- closed loop ----------------------------------------------------------------------------------------
def _bench_module():
    import importlib.util
    import os
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts", "bench_planning_core.py")
    spec = importlib.util.spec_from_file_location("bench_planning_core", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("kind", ["trajectory", "trajectory-dwa"])
def test_closed_loop_reaches_goals_without_collisions(kind):
    """NavFn + this planner driving the simulator core (no ROS) on the built-in world
    between two seeded start/goal pairs, with the course lesson's parameters: both
    goals reached within tolerance, no collision."""
    bench = _bench_module()
    params = bench.load_move_base_params(bench.CONFIG)
    c = bench.closed_loop(params, bench.BUILTIN, 2, seed=0, planner_kind=kind)
    assert c["runs"] == 2 and c["local_planner"] == kind
    assert c["collisions"] == 0
    assert c["reached_share"] == 1.0, [(r["xy_error_m"], r["yaw_error_rad"], r["time_s"])
                                       for r in c["runs_detail"]]


def test_goal_approach_steps_by_hand():
    """The shared steps at the goal (goal_approach), on the negative side the test above
    does not reach: rotateToGoal from -0.3 rad/s toward a heading -0.5 rad away: -0.5, within
    0.3 +- 3.2 x 0.05 -> -0.46, under sqrt(2 x 3.2 x 0.5) = 1.79 -> -0.46; braking never
    passes zero."""
    from my_summit_path_planning.goal_approach import braked, rotate_to_goal_speed
    assert rotate_to_goal_speed(-0.5, -0.3, 3.2, 1.0, -1.0, 0.4, 0.05) == pytest.approx(-0.46)
    assert rotate_to_goal_speed(-0.05, 0.0, 3.2, 1.0, -1.0, 0.4, 0.05) == pytest.approx(-0.4)  # min_in_place
    assert braked(-0.3, 2.5, 0.05) == pytest.approx(-0.175)
    assert braked(0.1, 2.5, 0.05) == 0.0
