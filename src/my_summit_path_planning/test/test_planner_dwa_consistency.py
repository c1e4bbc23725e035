"""The global planner and DWA agree on where the robot fits; the fixes for DWA dead ends.

- A door: whenever NavFn (global costmap from config/) plans through it, DWA's footprint
  check (local footprint, covering circles) passes at every plan point with the plan's
  heading; a door narrower than the robot gets no plan.
- NavFn's A*-bounded potential equals the full Dijkstra where it settled cells, and the
  straightened path is near the Euclidean length in the open.
- DWA: pressed against a wall (clearance just below zero) it keeps moving instead of
  sitting still; a plan that winds round a wall to a goal near as the crow flies is
  driven, not spun on.
"""
import math
import os

import cv2
import numpy as np
import numpy.testing as npt
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D
from my_summit_path_planning.dwa import DWAConfig, DWAPlanner
from my_summit_path_planning.navfn import (POT_HIGH, GridGraph, NavFn, NavfnConfig, dijkstra_reference,
                                           navfn_costs)
from my_summit_path_planning.params import build_costmap, load_move_base_params

CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config")
RES = 0.05  # [m/cell]


def _door_map(gap_cells):
    """8 m x 4 m room split by a wall at x = 4 m with a door of gap_cells free cells."""
    occ = np.zeros((80, 160), np.int8)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = 100
    occ[:, 80] = 100
    y0 = 40 - gap_cells // 2
    occ[y0:y0 + gap_cells, 80] = 0
    return occ


def _global(params, occ):
    g = build_costmap(params.global_costmap, "global_costmap")
    g.layer("static_layer").set_map(occ, RES, (0.0, 0.0, 0.0))
    g.update_map(0.0, 0.0, 0.0)
    return g


def _dwa_clearance(dwa, cm, path):
    """DWA's footprint clearance [m] at each plan point, heading along the plan."""
    blocked = (cm.data == cv.LETHAL_OBSTACLE) | (cm.data == cv.NO_INFORMATION)
    dist = cv2.distanceTransform((~blocked).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * cm.resolution
    # Heading along the plan over +-HALF_BODY points (the plan's 2.5 cm steps wiggle).
    half_body = 8
    n = len(path)
    i0 = np.clip(np.arange(n) - half_body, 0, n - 1)
    i1 = np.clip(np.arange(n) + half_body, 0, n - 1)
    d = path[i1] - path[i0]
    yaw = np.arctan2(d[:, 1], d[:, 0])
    return dwa._footprint_clearance(dist, cm, path[:, 0], path[:, 1], yaw)


@pytest.mark.parametrize("gap_cells", range(11, 19))
def test_planner_only_uses_doors_dwa_can_pass(gap_cells):
    params = load_move_base_params(CONFIG)
    occ = _door_map(gap_cells)
    g = _global(params, occ)
    loc = build_costmap(params.local_costmap, "local_costmap")
    dwa = DWAPlanner(params.dwa, loc.footprint)
    r = NavFn(params.navfn).make_plan(g.master, (2.0, 2.0), (6.0, 2.0), tolerance=0.0)
    width = gap_cells * RES  # [m] free gap between the jambs
    if width < 0.62:  # the Summit XL is 0.62 m wide
        assert not r.ok, f"a {width:.2f} m door got a plan"
    if r.ok:
        assert _dwa_clearance(dwa, g.master, r.path).min() >= 0.0
    if width >= 0.75:
        assert r.ok, r.reason


@pytest.mark.parametrize("seed", range(4))
def test_astar_potential_is_exact_where_settled(seed):
    rng = np.random.default_rng(seed)
    h, w = 20, 24
    costs = rng.integers(0, 200, size=(h, w)).astype(np.uint8)
    costs[rng.random((h, w)) < 0.15] = cv.LETHAL_OBSTACLE
    cc = navfn_costs(costs, False)
    free = np.argwhere(np.isfinite(cc))
    g = GridGraph(cc)
    for _ in range(5):
        (sy, sx), (ty, tx) = free[rng.integers(len(free))], free[rng.integers(len(free))]
        pot = g.potential_toward(sy * w + sx, ty * w + tx)
        ref = np.array(dijkstra_reference(cc.tolist(), (int(sx), int(sy))))
        settled = pot < POT_HIGH
        npt.assert_allclose(pot[settled], ref[settled], rtol=1e-9, atol=1e-9)
        assert settled[ty, tx] == (ref[ty, tx] < POT_HIGH)


def test_astar_settles_less_than_the_full_search():
    cc = np.full((100, 200), float(50))
    g = GridGraph(cc)
    pot = g.potential_toward(50 * 200 + 10, 50 * 200 + 190)
    assert pot[50, 190] == pytest.approx(180 * 50)
    assert (pot < POT_HIGH).mean() < 0.5


def test_path_is_straight_in_the_open():
    cm = Costmap2D(200, 200, RES)
    r = NavFn(NavfnConfig(allow_unknown=False)).make_plan(cm, (0.5, 0.5), (9.0, 4.0))
    assert r.ok
    straight = math.hypot(8.5, 3.5)
    assert r.length <= straight * 1.01  # an octile path would be ~5 % longer here
    assert r.length >= straight - 1e-9


def _local(footprint, walls, size=140, origin=(-3.5, -3.5)):
    from my_summit_path_planning.costmap import LayeredCostmap
    lc = LayeredCostmap.from_plugins([{"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}],
                                     {"inflation_layer": {"inflation_radius": 0.8, "cost_scaling_factor": 5.0}},
                                     Costmap2D(size, size, RES, *origin), footprint)
    m = lc.master
    for x0, y0, x1, y1 in walls:
        a = m.world_to_map_no_bounds(x0, y0)
        b = m.world_to_map_no_bounds(x1, y1)
        m.data[max(0, a[1]):b[1] + 1, max(0, a[0]):b[0] + 1] = cv.LETHAL_OBSTACLE
    lc.layers[0].update_costs(m, (0, 0, size, size))
    return m


def _drive(planner, m, pose, steps, dt=0.05):
    vel = (0.0, 0.0, 0.0)
    poses, results = [pose], []
    for _ in range(steps):
        r = planner.compute_velocity(pose, vel, m)
        results.append(r)
        if r.goal_reached:
            break
        vel = r.cmd
        x, y, th = pose
        pose = (x + vel[0] * math.cos(th) * dt, y + vel[0] * math.sin(th) * dt, th + vel[2] * dt)
        poses.append(pose)
    return poses, results


def test_keeps_moving_when_pressed_against_a_wall(footprint):
    params = load_move_base_params(CONFIG)
    # Stopped with the nose 0.12 rad into a wall on the right: the front circle's
    # clearance is just below zero (escape mode). Before, every sample dipped below the
    # (nearest-cell, hence jumpy) clearance and the robot never moved again.
    m = _local(footprint, [(-3.5, -0.40, 3.5, -0.36)])
    planner = DWAPlanner(params.dwa, footprint)
    plan = np.column_stack([np.linspace(0.0, 3.0, 61), np.full(61, 0.4)])
    planner.set_plan(plan, 0.0)
    pose = (0.0, 0.0, -0.12)
    r = planner.compute_velocity(pose, (0.0, 0.0, 0.0), m)
    assert r.ok and r.mode == "escape", r.reason
    poses, results = _drive(planner, m, pose, 40)
    assert all(res.ok for res in results), [res.reason for res in results if not res.ok][:1]
    assert poses[-1][0] > 0.3
    assert min(p[1] for p in poses) > -0.05   # it does not cut further into the wall


def test_drives_a_plan_that_winds_round_a_wall(footprint):
    params = load_move_base_params(CONFIG)
    # A wall between the robot (x = 0) and the goal (x = 1.5); the plan goes round its end.
    m = _local(footprint, [(0.7, -3.5, 0.8, 1.0)])
    planner = DWAPlanner(params.dwa, footprint)
    pts = np.array([[0.0, 0.0], [0.0, 2.0], [1.5, 2.0], [1.5, 0.0]])
    plan = np.concatenate([np.linspace(pts[i], pts[i + 1], 41)[:-1] for i in range(3)] + [pts[-1:]])
    planner.set_plan(plan, -math.pi / 2)
    poses, results = _drive(planner, m, (0.0, 0.0, math.pi / 2), 300)
    assert results[-1].goal_reached, results[-1].reason
    spins = sum(1 for r in results if r.mode == "dwa" and abs(r.cmd[0]) < 0.05)
    assert spins < 40
