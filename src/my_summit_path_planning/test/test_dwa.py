"""DWA: corridor driving, stopping for a wall, goal latching, escape from the inscribed zone."""
import math

import numpy as np
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D, LayeredCostmap
from my_summit_path_planning.dwa import (DWAConfig, DWAPlanner, OscillationFlags, dynamic_window,
                                         sample_velocities, simulate)

CFG = dict(max_vel_x=1.5, min_vel_x=0.0, max_vel_y=0.0, min_vel_y=0.0, max_vel_trans=1.5,
           min_vel_trans=0.1, max_vel_theta=3.0, min_vel_theta=0.3, acc_lim_x=2.5,
           acc_lim_theta=5.0, vx_samples=20, vy_samples=1, vth_samples=40,
           xy_goal_tolerance=0.15, yaw_goal_tolerance=0.15, latch_xy_goal_tolerance=True,
           goal_distance_bias=20.0, occdist_scale=0.02)


def local_costmap(footprint, walls, size=140, res=0.05, origin=(-3.5, -3.5)):
    """A rolling-window-sized costmap with lethal walls (list of (x0, y0, x1, y1) [m]) and inflation."""
    lc = LayeredCostmap.from_plugins([{"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}],
                                     {"inflation_layer": {"inflation_radius": 0.8, "cost_scaling_factor": 5.0}},
                                     Costmap2D(size, size, res, *origin), footprint)
    m = lc.master
    for x0, y0, x1, y1 in walls:
        a = m.world_to_map_no_bounds(x0, y0)
        b = m.world_to_map_no_bounds(x1, y1)
        m.data[max(0, a[1]):b[1] + 1, max(0, a[0]):b[0] + 1] = cv.LETHAL_OBSTACLE
    lc.layers[0].update_costs(m, (0, 0, size, size))
    return m


def footprint_hits(m, footprint, x, y, yaw):
    poly = footprint.oriented(x, y, yaw)
    xs, ys = np.meshgrid(np.linspace(0, 1, 15), np.linspace(0, 1, 15))
    a, b, d = poly[0], poly[1], poly[3]
    pts = a + xs.ravel()[:, None] * (b - a) + ys.ravel()[:, None] * (d - a)
    mx, my, inside = m.world_to_map_array(pts)
    return (~inside).any() or (m.data[my, mx] == cv.LETHAL_OBSTACLE).any()


def test_dynamic_window_and_samples():
    cfg = DWAConfig(**CFG)
    (x0, x1), _, (t0, t1) = dynamic_window(cfg, (0.0, 0.0, 0.0))
    assert (x0, x1) == (0.0, pytest.approx(0.125)) and (t0, t1) == (pytest.approx(-0.25), pytest.approx(0.25))
    s = sample_velocities(cfg, dynamic_window(cfg, (1.0, 0.0, 0.0)), holonomic=False)
    assert (s[:, 0] <= 1.125 + 1e-9).all() and (s[:, 1] == 0).all()
    assert np.any(s[:, 2] == 0.0)   # zero rotation is always a sample when spanned
    x, y, th = simulate((0.0, 0.0, 0.0), np.array([[1.0, 0.0, 0.0]]), 0.1, 10)
    assert x[0, -1] == pytest.approx(1.0) and y[0, -1] == pytest.approx(0.0)


def run(planner, m, footprint, pose, vel=(0.0, 0.0, 0.0), steps=60, dt=0.05):
    """Drive a perfect robot (velocity = command) for steps periods; returns poses and results."""
    poses, results = [pose], []
    for _ in range(steps):
        r = planner.compute_velocity(pose, vel, m)
        results.append(r)
        if r.goal_reached:
            break
        vel = r.cmd
        x, y, yaw = pose
        pose = (x + (vel[0] * math.cos(yaw) - vel[1] * math.sin(yaw)) * dt,
                y + (vel[0] * math.sin(yaw) + vel[1] * math.cos(yaw)) * dt, yaw + vel[2] * dt)
        poses.append(pose)
        assert not footprint_hits(m, footprint, *pose)
    return poses, results


def test_corridor_collision_free_progress(footprint):
    walls = [(-3.5, 0.6, 3.5, 0.7), (-3.5, -0.7, 3.5, -0.6)]   # a 1.2 m corridor along x
    m = local_costmap(footprint, walls)
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    plan = np.column_stack([np.linspace(-2.0, 3.0, 101), np.zeros(101)])
    planner.set_plan(plan, 0.0)
    poses, results = run(planner, m, footprint, (-2.0, 0.05, 0.1), steps=40)
    assert all(r.ok for r in results)
    assert poses[-1][0] > -0.5           # drove at least 1.5 m in 2 s
    assert abs(poses[-1][1]) < 0.2


def test_stops_for_a_wall(footprint):
    walls = [(0.9, -3.0, 1.0, 3.0)]      # wall across the path 1 m ahead
    m = local_costmap(footprint, walls)
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    plan = np.column_stack([np.linspace(0.0, 3.0, 61), np.zeros(61)])
    planner.set_plan(plan, 0.0)
    poses, results = run(planner, m, footprint, (0.0, 0.0, 0.0), vel=(0.5, 0.0, 0.0), steps=60)
    assert max(p[0] for p in poses) < 0.9 - 0.36   # the front never reaches the wall


def test_goal_latch_and_rotate(footprint):
    m = local_costmap(footprint, [])
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    plan = np.column_stack([np.linspace(0.0, 1.0, 21), np.zeros(21)])
    planner.set_plan(plan, math.pi / 2)
    poses, results = run(planner, m, footprint, (0.0, 0.0, 0.0), steps=200)
    assert results[-1].goal_reached
    x, y, yaw = poses[-1]
    assert math.hypot(x - 1.0, y) <= 0.15 + 0.05
    assert abs((yaw - math.pi / 2 + math.pi) % (2 * math.pi) - math.pi) <= 0.15
    modes = [r.mode for r in results]
    assert "rotate" in modes
    # Once rotating, it never goes back to driving (no wiggling at the goal); within the
    # yaw tolerance it brakes ("stop") and the goal counts only once it stands still.
    first = modes.index("rotate")
    assert all(mo in ("rotate", "stop", "goal") for mo in modes[first:])
    assert modes[first:].index("goal") > modes[first:].index("stop")


def test_escape_from_inscribed_zone(footprint):
    walls = [(-3.5, 0.30, 3.5, 0.45)]    # wall cells from 0.30 m left of the centre: inscribed
    m = local_costmap(footprint, walls)
    assert m.cost_at(0.0, 0.0) == cv.INSCRIBED_INFLATED_OBSTACLE
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    plan = np.column_stack([np.linspace(0.0, 3.0, 61), np.full(61, -0.6)])
    planner.set_plan(plan, 0.0)
    r = planner.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert r.ok and r.mode == "escape" and r.cmd != (0.0, 0.0, 0.0)


def test_oscillation_flags():
    f = OscillationFlags(0.05, 0.2)
    f.update((0, 0, 0), (0.0, 0.0, 0.5), 0.1)
    f.update((0, 0, 0.01), (0.0, 0.0, -0.5), 0.1)
    assert f.rot_neg_only
    s = np.array([[0.0, 0.0, 0.5], [0.0, 0.0, -0.5]])
    assert f.forbidden(s).tolist() == [True, False]
    f.update((0, 0, 0.5), (0.0, 0.0, -0.5), 0.1)   # turned > reset angle: flags cleared
    assert not f.forbidden(s).any()


def test_latch_released_after_coasting_past_the_goal(footprint):
    """Latched within tolerance at speed, braked 0.4 m past the goal: it must not turn on
    the spot and report the goal; it drives back instead."""
    m = local_costmap(footprint, [])
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    plan = np.column_stack([np.linspace(0.0, 1.0, 21), np.zeros(21)])
    planner.set_plan(plan, 0.0)
    r = planner.compute_velocity((0.95, 0.0, 0.0), (0.8, 0.0, 0.0), m)   # inside: latches, brakes
    assert planner.xy_latched and r.mode == "stop"
    r = planner.compute_velocity((1.4, 0.0, 0.0), (0.0, 0.0, 0.0), m)    # coasted 0.4 m past
    assert not planner.xy_latched and not r.goal_reached
    assert r.mode not in ("rotate", "goal")
