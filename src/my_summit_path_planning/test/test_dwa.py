"""DWA: corridor driving, stopping for a wall, goal latching, escape from the inscribed zone."""
import math

import numpy as np
import pytest

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D, Footprint, LayeredCostmap
from my_summit_path_planning.clearance import ESCAPE_TOL
from my_summit_path_planning.dwa import DWAConfig, DWAPlanner, dynamic_window, sample_velocities, simulate
from my_summit_path_planning.latency import LatencyMeter
from my_summit_path_planning.oscillation import OscillationFlags

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


def reinflated(m, footprint):
    """m with every cell but the lethal ones freed and inflated again as in the course."""
    m.data[m.data != cv.LETHAL_OBSTACLE] = cv.FREE_SPACE
    lc = LayeredCostmap.from_plugins([{"name": "inflation_layer", "type": "costmap_2d::InflationLayer"}],
                                     {"inflation_layer": {"inflation_radius": 0.8, "cost_scaling_factor": 5.0}},
                                     m, footprint)
    lc.layers[0].update_costs(m, (0, 0, m.size_x, m.size_y))
    return m


def recorded_costmap(footprint, cells):
    """A field failure's local costmap: the lethal cells (dx, dy) the laser marked, from the
    robot's cell (70, 70) of a 140 x 140 window at 0.05 m, inflated as in the course."""
    m = local_costmap(footprint, [])
    for dx, dy in cells:
        m.data[70 + dy, 70 + dx] = cv.LETHAL_OBSTACLE
    return reinflated(m, footprint)


def clearance_of(planner, m):
    """pose -> the planner's footprint clearance [m] from m's lethal cells."""
    import cv2
    blocked = m.data == cv.LETHAL_OBSTACLE
    dist = cv2.distanceTransform((~blocked).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * m.resolution
    return lambda p: float(planner._footprint_clearance(dist, m, np.array(p[0]), np.array(p[1]), np.array(p[2])))


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


def advance(pose, vel, dt=0.05):
    """A perfect robot's pose after holding body velocity vel (vx, vy, vth) for dt [s]
    (base_local_planner's Euler step: translate with the heading at the start, then turn)."""
    x, y, yaw = pose
    return (x + (vel[0] * math.cos(yaw) - vel[1] * math.sin(yaw)) * dt,
            y + (vel[0] * math.sin(yaw) + vel[1] * math.cos(yaw)) * dt, yaw + vel[2] * dt)


def drive_turn_around(footprint, pose, m, clear, check=None, dt=0.05):
    """Run a TurnAroundRecovery from pose on m for up to 20 s, driving a robot that ramps
    to each command (acc_lim_x 2.5 m/s^2, acc_lim_theta 5 rad/s^2): (its last step, the
    end pose, the lowest clearance on the way); check(pose), when given, must hold at
    every pose."""
    from my_summit_path_planning.recovery import TurnAroundRecovery
    rec = TurnAroundRecovery(footprint, frequency=1.0 / dt)
    rec.start(pose)
    vel, lowest = (0.0, 0.0, 0.0), clear(pose)
    for _ in range(int(round(20.0 / dt))):
        s = rec.step(pose, vel, m)
        if s.done:
            break
        vel = (vel[0] + float(np.clip(s.cmd[0] - vel[0], -2.5 * dt, 2.5 * dt)), 0.0,
               vel[2] + float(np.clip(s.cmd[2] - vel[2], -5.0 * dt, 5.0 * dt)))
        pose = advance(pose, vel, dt)
        lowest = min(lowest, clear(pose))
        assert check is None or check(pose), pose
    return s, pose, lowest


def run(planner, m, footprint, pose, vel=(0.0, 0.0, 0.0), steps=60, dt=0.05):
    """Drive a perfect robot (velocity = command) for steps periods; returns poses and results."""
    poses, results = [pose], []
    for _ in range(steps):
        r = planner.compute_velocity(pose, vel, m)
        results.append(r)
        if r.goal_reached:
            break
        vel = r.cmd
        pose = advance(pose, vel, dt)
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
    """Started on an inscribed cell (0.30 m from a wall, within the 0.31 m half-width),
    real dwa_local_planner rejects every trajectory and the robot never moves; escape
    mode moves it."""
    walls = [(-3.5, 0.30, 3.5, 0.45)]    # wall cells from 0.30 m left of the centre: inscribed
    m = local_costmap(footprint, walls)
    assert m.cost_at(0.0, 0.0) == cv.INSCRIBED_INFLATED_OBSTACLE
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    plan = np.column_stack([np.linspace(0.0, 3.0, 61), np.full(61, -0.6)])
    planner.set_plan(plan, 0.0)
    r = planner.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert r.ok and r.mode == "escape" and r.cmd != (0.0, 0.0, 0.0)


def test_backs_up_a_plan_behind_it_where_no_turn_fits(footprint):
    """Escape mode backs up along the plan where reversing regains no clearance: in a
    gap barely wider than the robot with its plan behind it there is no room to turn, and
    driving on leads away (the multi-robot crossing, test_pressed_against_a_ragged_wall_
    drives_on: reversing was allowed only where it regained clearance). Hand-built: a
    0.63 m corridor, the plan 3 m back down it; the robot backs down it, its clearance
    never dropping, where otherwise it crept forward, away from the plan."""
    m = local_costmap(footprint, [(-3.5, 0.30, 3.5, 0.45), (-3.5, -0.45, 3.5, -0.33)])
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    planner.set_plan(np.column_stack([np.linspace(0.0, -3.0, 61), np.zeros(61)]), math.pi)
    clear = clearance_of(planner, m)
    pose, vel = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    c0 = clear(pose)
    for _ in range(40):                         # 2 s
        r = planner.compute_velocity(pose, vel, m)
        assert r.ok and r.mode == "escape" and r.cmd[0] < 0.0, (r.cmd, r.reason)
        vel = r.cmd
        pose = advance(pose, vel)
        assert clear(pose) >= c0 - 1e-6
    assert pose[0] < -0.3, pose


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


TABLE_LEGS_X = (13.45, 14.95)   # [m] world x of the table's legs (course_building.world.yaml)
TABLE_LEGS_Y = (-0.4, 0.4)      # [m] relative to the spot's y (legs at y 4.8 / 5.6, spot 5.2)
LEG_RADIUS = 0.04               # [m]


def rect_distance(footprint, pose, p):
    """Distance [m] from point p to the footprint rectangle at pose (0 inside)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = p[0] - x, p[1] - y
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    hx, hy = np.abs(footprint.polygon).max(axis=0)
    return math.hypot(max(abs(lx) - hx, 0.0), max(abs(ly) - hy, 0.0))


def table_scene(footprint, robot_x, ghost=None):
    """The course's table spot in the robot's frame: the robot at (0, 0) facing -x (west),
    the table's four thin legs (radius 0.04 m) ahead at x robot_x - 13.45 / 14.95,
    y +-0.4; ghost: an optional (x, y) lethal cell (a stale mark in the laser's rear
    blind sector). Returns the inflated local costmap."""
    m = local_costmap(footprint, [])
    for lx in TABLE_LEGS_X:
        for ly in TABLE_LEGS_Y:
            cx, cy = lx - robot_x, ly
            xs, ys = np.meshgrid(np.arange(cx - 0.05, cx + 0.051, 0.01), np.arange(cy - 0.05, cy + 0.051, 0.01))
            inside = np.hypot(xs - cx, ys - cy) <= LEG_RADIUS
            mx, my, ok = m.world_to_map_array(np.column_stack([xs[inside], ys[inside]]))
            m.data[my[ok], mx[ok]] = cv.LETHAL_OBSTACLE
    if ghost is not None:
        c = m.world_to_map(*ghost)
        m.data[c[1], c[0]] = cv.LETHAL_OBSTACLE
    return reinflated(m, footprint)


@pytest.mark.parametrize("robot_x", [15.8, 15.6, 15.55])
def test_table_spot_robot_can_turn_and_leave(footprint, robot_x):
    """Field failure (issue 5): after the goal beside the table (robot facing the legs,
    stopped at or a little nearer than the spot 0.85 m east of them), the next goal lies
    behind it. DWA said 'all 164 samples collide' for 30 s and rotate_recovery 'turning
    would hit an obstacle', though the real rectangle clears the legs when turning on the
    spot (circumscribed radius 0.475 m): the axis circles of the footprint check stick out
    0.25 m past the front and back, the whole sim_time horizon (1.9 s) had to stay free,
    and from rest no in-place turn was in the window (acc_lim_theta x sim_period 0.25 rad/s
    < min_vel_theta 0.3). With a stale mark 0.4 m behind the rear edge no backing up
    either. Now: a valid command, and the rotation check passes."""
    from my_summit_path_planning.recovery import RotateRecovery
    m = table_scene(footprint, robot_x, ghost=(0.36 + 0.40, 0.05))
    cfg = DWAConfig(**dict(CFG, xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, footprint)
    # The plan back to the hall: south round the table's end, then west.
    plan = np.array([(0.0, 0.0), (0.0, -0.4), (-0.3, -1.0), (-1.5, -1.2), (-3.0, -1.2)])
    from my_summit_path_planning.navfn import resample_path
    planner.set_plan(resample_path(plan, 0.025), 0.0)
    pose = (0.0, 0.0, math.pi)
    r = planner.compute_velocity(pose, (0.0, 0.0, 0.0), m)
    assert r.ok, r.reason
    rot = RotateRecovery(footprint, acc_lim_th=5.0, max_rotational_vel=3.0, min_in_place_rotational_vel=0.3)
    rot.start(pose)
    step = rot.step(pose, (0.0, 0.0, 0.0), m)
    assert step.ok and not step.reason, step.reason
    # And it gets going: within 3 s it has turned toward the plan and left the spot without
    # touching a leg (the legs as they are: disks of radius LEG_RADIUS; the helper run()
    # checks whole cells, which the footprint check may graze by a few millimetres).
    poses, results = [pose], []
    vel = (0.0, 0.0, 0.0)
    for _ in range(60):
        r = planner.compute_velocity(pose, vel, m)
        results.append(r)
        vel = r.cmd   # (0, 0, 0) when not ok
        pose = advance(pose, vel)
        poses.append(pose)
        for lx in TABLE_LEGS_X:
            for ly in TABLE_LEGS_Y:
                assert rect_distance(footprint, pose, (lx - robot_x, ly)) > LEG_RADIUS
    # (A cycle without a valid command stops the robot, as move_base does; the crude
    # one-step motion here may leave a chosen arc a hair inside the margin once.)
    failed = [res.reason for res in results if not res.ok]
    assert len(failed) <= len(results) // 10, failed[:2]
    assert math.hypot(poses[-1][0], poses[-1][1]) > 0.5


def test_no_valid_trajectory_reason_counts_constraints(footprint):
    """The 'no valid trajectory' reason says which constraint rejected how many samples."""
    m = local_costmap(footprint, [(0.40, -3.0, 0.50, 3.0)])   # a wall 4 cm ahead of the front edge
    planner = DWAPlanner(DWAConfig(**dict(CFG, min_vel_theta=0.3)), footprint)
    plan = np.column_stack([np.linspace(0.0, 3.0, 61), np.zeros(61)])
    planner.set_plan(plan, 0.0)
    planner.oscillation.rot_pos_only = True     # as after a reversal of rotation: no left turns
    planner.oscillation.prev_stationary = (0.0, 0.0, 0.0)
    r = planner._dwa_step((0.0, 0.0, 0.0), (0.3, 0.0, 0.0), m, force_escape=False)
    assert not r.ok
    assert r.reason.startswith(f"no valid trajectory: of {r.n_samples} samples ")
    assert " collide" in r.reason and " would oscillate" in r.reason


@pytest.mark.parametrize("period", [0.05, 0.85])
@pytest.mark.parametrize("err0", [0.1, 0.8, 1.57, 3.1, -2.0])
def test_goal_approach_is_time_optimal_without_overshoot(err0, period):
    """rotation_speed on a base that tracks the command within acc_lim_theta (5 ms steps,
    commands every period): it stops inside the yaw tolerance, never turns past the goal
    heading, and takes at most 15 % longer than the bang-bang bound, plus two periods of a
    late loop.

    Regression (period 0.85, explore_slot_room under load): the profile was planned for
    the nominal 50 ms while a late loop held each command 0.85 s, and min_vel_theta 0.3
    held that long turns 0.26 rad, more than the whole tolerance window (0.12): the robot
    turned back and forth across the goal heading until move_base's 10 s oscillation
    timeout. The command is now planned for the period it stays in force."""
    from my_summit_path_planning.goal_approach import rotation_speed
    from summit_nav_common.geometry import wrap_angle
    acc, vmax, vmin, tol, step = 5.0, 3.0, 0.3, 0.06, 0.005
    yaw, w, t, passed = 0.0, 0.0, 0.0, False
    while t < 5.0:
        err = wrap_angle(err0 - yaw)
        if abs(err) <= tol:
            if abs(w) <= 0.05:
                break
            cmd = math.copysign(max(0.0, abs(w) - acc * period), w)
        else:
            cmd = rotation_speed(err, w, acc, vmax, vmin, tol, period)
        for _ in range(int(round(period / step))):
            w += float(np.clip(cmd - w, -acc * step, acc * step))
            yaw += w * step
            t += step
            passed |= wrap_angle(err0 - yaw) * err0 < -tol
    assert abs(wrap_angle(err0 - yaw)) <= tol and not passed
    e = abs(err0)
    bound = 2.0 * math.sqrt(e / acc) if e < vmax ** 2 / acc else e / vmax + vmax / acc
    assert t <= 1.15 * bound + period + (2 * period if period > 0.05 else 0.0)


def test_escape_floor_follows_a_clearance_drop(footprint):
    """The escape floor only rises while escaping (no creeping into the wall), but when the
    clearance drops below it for reasons of its own (a new obstacle cell marked next to the
    robot), it must follow: otherwise no sample is ever valid again (issue 5: the robot
    stood 3 cm from a box for 30 s, 'all 166 samples collide (escape mode)')."""
    walls = [(-3.5, 0.30, 3.5, 0.45)]    # wall cells from 0.30 m left of the centre: inscribed
    m = local_costmap(footprint, walls)
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    plan = np.column_stack([np.linspace(0.0, 3.0, 61), np.full(61, -0.6)])
    planner.set_plan(plan, 0.0)
    r = planner.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert r.ok and r.mode == "escape"
    planner._escape_floor = 0.0    # a floor the robot's clearance is now well below
    r = planner.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert r.ok and r.mode == "escape", r.reason


def test_boxed_in_corner_backs_out(footprint):
    """Field failure (patrol / course project, return to the hall): the robot coasted past
    its goal into the corner by the hall's shelves: nose 0.27 m from a wall, a wall along
    its left side 0.06 m away. No turn keeps the clearance, no forward move exists and
    backing up parallel to the side wall regains none: escape mode rejected every sample
    and move_base aborted after its recoveries. Now it backs out along the wall, without
    touching it. (Turning round while the side wall is still within the corners' sweep is
    not solved: the goal behind it is not reached here.) The planner has the course's
    footprint_padding (0.01 m), which escape mode may spend; contact is checked on the
    unpadded footprint."""
    front = 0.36 + 0.27
    side = 0.31 + 0.06
    # robot at (0, 0) facing -x: the wall ahead at x <= -front, the side wall (its left:
    # -y when facing -x) at y <= -side from the front wall to 1.5 m behind the robot
    m = local_costmap(footprint, [(-front - 0.3, -3.0, -front, 3.0), (-front, -side - 0.3, 1.5, -side)])
    cfg = DWAConfig(**dict(CFG, xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, Footprint.from_params(footprint.oriented(0.0, 0.0, 0.0).tolist(), padding=0.01))
    from my_summit_path_planning.navfn import resample_path
    planner.set_plan(resample_path(np.array([(0.0, 0.0), (1.0, 0.3), (2.5, 0.6)]), 0.025), 0.0)
    poses, results = run(planner, m, footprint, (0.0, 0.0, math.pi), steps=300)
    assert results[0].ok, results[0].reason
    assert results[0].cmd[0] < 0.0           # it backs out first
    assert max(p[0] for p in poses) > 1.0, poses[-1]   # out of the corner, no contact (run checks)


def test_boxed_in_with_the_plan_ahead_backs_straight_out(footprint):
    """Boxed in (escape_admissibility's first fallback): nose 0.27 m from a wall, its left
    side pressed against another (the marked cells reach a centimetre into the outline, as
    laser marks reach past the surface), the plan turning off to the right ahead. Every
    turn sweeps a corner into a wall, every forward move closes on the front one, and
    backing up parallel to the side wall regains no clearance and leads away from the plan,
    so the ordinary escape rules (regain back_out, or go back along the plan) and the
    creep-back fallback (regain creep_back by the stop) admit nothing. The fallback admits
    reversing that loses no clearance: the robot backs straight out along the wall. The
    corner of test_boxed_in_corner_backs_out had the same rule behind it when it was added
    (23f6691), but its plan lies behind the robot, which the along-the-plan rule admits since;
    with this fallback removed the robot here gets no command in 119 of 120 cycles."""
    from my_summit_path_planning.navfn import resample_path
    front, side = 0.36 + 0.27, 0.31 + 0.035
    # robot at (0, 0) facing -x: the wall ahead at x <= -front, the side wall (its left) at
    # y <= -side from the front wall to 1.5 m behind it; the plan goes off to the right (+y)
    m = local_costmap(footprint, [(-front - 0.3, -3.0, -front, 3.0), (-front, -side - 0.3, 1.5, -side)])
    planner = DWAPlanner(DWAConfig(**dict(CFG, xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06)), footprint)
    planner.set_plan(resample_path(np.array([(0.0, 0.0), (0.0, 1.0), (0.3, 2.5)]), 0.025), 0.0)
    clear = clearance_of(planner, m)
    pose, vel = (0.0, 0.0, math.pi), (0.0, 0.0, 0.0)
    c0 = clear(pose)
    assert -0.05 < c0 < 0.0                  # pressed into the side wall's marks
    for _ in range(60):
        r = planner.compute_velocity(pose, vel, m)
        assert r.ok and r.mode == "escape", r.reason
        assert r.cmd[0] < 0.0                # backing out
        vel = r.cmd
        pose = advance(pose, vel)
        assert clear(pose) >= c0 - ESCAPE_TOL   # along the wall, not into it
    assert pose[0] > 0.3 and abs(pose[1]) < 0.02, pose


def test_late_control_loop_brakes_in_time(footprint):
    """A loaded machine: each command stays in force 0.4 s (8 periods), the robot tracks it
    within its acceleration limits. Told the measured latency (move_base measures it), DWA
    brakes early enough to stop at the goal, 0.7 m before a wall; planning for one nominal
    period it coasted 0.3 m past the goal and turned circles there."""
    hold, dt, goal_x = 0.4, 0.01, 2.5
    m = local_costmap(footprint, [(3.2, -3.0, 3.3, 3.0)])
    planner = DWAPlanner(DWAConfig(**dict(CFG, xy_goal_tolerance=0.10)), footprint)
    planner.set_plan(np.column_stack([np.linspace(-3.0, goal_x, 111), np.zeros(111)]), 0.0)
    planner.set_control_latency(hold)
    assert planner.latency == pytest.approx(hold)
    pose, vel, max_x = (-3.0, 0.0, 0.0), (1.5, 0.0, 0.0), -3.0
    for _ in range(100):
        r = planner.compute_velocity(pose, vel, m)
        if r.goal_reached:
            break
        for _ in range(int(round(hold / dt))):
            vx = vel[0] + float(np.clip(r.cmd[0] - vel[0], -2.5 * dt, 2.5 * dt))
            vth = vel[2] + float(np.clip(r.cmd[2] - vel[2], -5.0 * dt, 5.0 * dt))
            vel = (vx, 0.0, vth)
            x, y, yaw = pose
            pose = (x + vx * math.cos(yaw) * dt, y + vx * math.sin(yaw) * dt, yaw + vth * dt)
            max_x = max(max_x, pose[0])
            assert not footprint_hits(m, footprint, *pose)
    assert r.goal_reached
    assert max_x <= goal_x + 0.10
    assert math.hypot(pose[0] - goal_x, pose[1]) <= 0.10
    assert abs(pose[2]) <= 0.06 + 0.05
    planner.set_control_latency(0.001)          # never below one control period
    assert planner.latency == pytest.approx(planner.config.sim_period)


# The local costmap around robot_0 in the multi-robot crossing (rostest, willow-full), cells
# (dx, dy) from the robot's cell as the laser marked them: the hall's clutter on its right
# (a ragged block of cells 0.34 m from its centre), walls behind and to the left.
CROSSING_CELLS = [
    (-22, -6), (-22, -3), (-21, -11), (-21, -10), (-21, -9), (-21, -8), (-21, -7), (-21, -6), (-21, -3),
    (-21, -2), (-21, -1), (-21, 0), (-21, 1), (-21, 2), (-21, 3), (-21, 4), (-21, 6), (-21, 7), (-21, 8),
    (-21, 9), (-21, 10), (-20, -12), (-20, -11), (-20, -10), (-20, -9), (-20, -8), (-20, -7), (-20, -4),
    (-20, -3), (-20, -2), (-20, -1), (-20, 0), (-20, 1), (-20, 2), (-20, 3), (-20, 4), (-20, 6), (-20, 7),
    (-20, 8), (-20, 9), (-20, 10), (-19, -11), (-19, 3), (-19, 4), (-19, 5), (-19, 6), (-18, -15),
    (-18, 2), (-18, 3), (-18, 4), (-18, 5), (-18, 6), (-17, -15), (-17, -14), (-10, -20), (-9, -20),
    (-9, -19), (-8, -22), (-8, -20), (-8, -19), (-7, -22), (-7, -21), (-7, -20), (-7, -19), (-6, -22),
    (-6, -21), (-6, -20), (-6, -19), (-5, -20), (-5, -19), (-4, -21), (-4, -20), (-4, -19), (6, -5),
    (6, -4), (6, -3), (7, -4), (7, -3), (8, -4), (8, -3), (9, -4), (9, -3), (9, -2), (9, 7), (9, 8),
    (9, 9), (10, -6), (10, -5), (10, -4), (10, -3), (10, 7), (10, 8), (10, 9), (11, -6), (11, -5),
    (11, -3), (11, 7), (11, 8), (12, -6), (12, -3), (12, 7), (12, 8), (13, -6), (13, 7), (13, 8), (13, 19),
    (13, 20), (14, -6), (14, 7), (14, 8), (14, 19), (15, -6), (15, -5), (15, 7), (15, 8), (15, 9),
    (16, -6), (16, -5), (17, 7), (18, 7), (18, 8), (18, 9), (19, 6), (19, 7), (19, 8), (20, 6), (20, 7),
    (20, 8), (21, 7)]


def test_pressed_against_a_ragged_wall_drives_on(footprint):
    """Field failure (multi-robot crossing): robot_0, pushed aside by robot_1, stood beside
    the clutter of the hall (nearest cell 0.35 m from its centre, -100 deg from its heading:
    clearance ~0 by DWA's measure), its plan turning back behind it. Normal DWA found no
    trajectory that kept clearance >= 0 and escape mode none that lost less than 1 mm:
    along a wall of laser-marked cells (ragged by a cell here and there) the measured
    clearance wobbles by millimetres along any motion, even straight along the wall; and
    backing up was allowed only where it regained clearance, not back along the plan.
    move_base aborted after 130 s of 'of 653 samples 653 collide (escape mode)'. Now the
    escape mode tolerates ESCAPE_TOL of clearance loss and may back up along the plan: the
    robot gets a valid command nearly every cycle and gets going, without cutting into the
    marked cells by more than that tolerance."""
    from my_summit_path_planning.navfn import resample_path
    res, frac = 0.05, (0.389, 0.854)
    m = recorded_costmap(footprint, CROSSING_CELLS)
    x0, y0 = -3.5 + (70 + frac[0]) * res, -3.5 + (70 + frac[1]) * res
    pose = (x0, y0, 1.2367)
    plan = np.array([(0.0, -0.01), (-0.05, -0.51), (0.43, -0.85), (0.99, -0.97), (1.5, -0.7), (1.9, -0.26),
                     (2.24, 0.23), (2.29, 0.79)]) + (x0, y0)
    # The crossing's DWA parameters (dwa_local_planner_params.yaml, max_vel_x 0.6).
    cfg = DWAConfig(**dict(CFG, max_vel_x=0.6, max_vel_trans=0.6, goal_distance_bias=20.0,
                           xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, footprint)
    planner.set_plan(resample_path(plan, 0.025), 0.0)
    clear = clearance_of(planner, m)
    c0 = clear(pose)
    assert 0.0 <= c0 < 0.01           # pressed against the clutter, not into it
    vel, results, start = (0.107, 0.0, -0.058), [], pose
    for _ in range(40):
        r = planner.compute_velocity(pose, vel, m)
        results.append(r)
        vel = r.cmd                   # (0, 0, 0) when not ok, as move_base stops the robot
        pose = advance(pose, vel)
        assert clear(pose) >= min(c0, 0.0) - 0.01 - 1e-3
    failed = [res.reason for res in results if not res.ok]
    assert len(failed) <= 4, failed[:2]
    assert math.hypot(pose[0] - start[0], pose[1] - start[1]) > 0.02 or abs(pose[2] - start[2]) > 0.2


# The local costmap around robot_0 in the multi-robot crossing (rostest, willow-full, t 15 s),
# cells (dx, dy) from the robot's cell as the laser marked them: robot_0, sent round the
# chairs while robot_1 stood on its goal, has driven north into the dead-end pocket between
# the hall's west wall (1 m to its left) and a row of chairs (0.35-0.5 m to its right); the
# pocket's mouth is behind it to the south.
POCKET_CELLS = [
    (-22, -7), (-22, 13), (-21, -7), (-21, -4), (-21, 13), (-21, 14), (-21, 15), (-21, 16),
    (-20, -29), (-20, -28), (-20, -27), (-20, -26), (-20, -25), (-20, -24), (-20, -23), (-20, -22),
    (-20, -20), (-20, -17), (-20, -16), (-20, -15), (-20, -9), (-20, -8), (-20, -7), (-20, -4),
    (-20, -3), (-20, 13), (-20, 14), (-20, 15), (-20, 16), (-19, -29), (-19, -28), (-19, -27),
    (-19, -25), (-19, -24), (-19, -17), (-19, -9), (-19, -3), (-18, -32), (-18, -31), (-18, -30),
    (-18, -29), (-18, -19), (-18, -18), (-18, -14), (-18, -12), (-18, -9), (-17, -29), (-16, -19),
    (-16, -7), (-16, 15), (-16, 16), (-15, -19), (-15, -12), (-15, -11), (-15, -10), (-15, -8),
    (-15, -7), (-15, -4), (-15, -3), (-15, -2), (-15, -1), (-15, 0), (-15, 1), (-15, 6), (-15, 7),
    (-15, 8), (-15, 9), (-15, 15), (-15, 16), (-14, -21), (-14, -20), (-14, -15), (-14, -13),
    (-14, -12), (-14, -11), (-14, -10), (-14, -9), (-14, -8), (-14, -7), (-14, -6), (-14, -5),
    (-14, -4), (-14, -3), (-14, -2), (-14, -1), (-14, 0), (-14, 1), (-14, 2), (-14, 5), (-14, 6),
    (-14, 7), (-14, 8), (-14, 9), (-14, 15), (-14, 16), (-13, -22), (-13, -21), (-13, -20),
    (-13, -16), (-13, -15), (-13, -14), (-13, 1), (-13, 2), (-13, 3), (-13, 4), (-13, 5),
    (-12, -22), (-12, -21), (-12, -17), (-12, -16), (-12, -15), (-12, -14), (-12, 1), (-12, 2),
    (-12, 3), (-12, 4), (-12, 5), (-11, -21), (-10, -21), (-9, -21), (-8, -23), (-8, -22),
    (-8, -21), (-8, -20), (-3, -21), (-3, -20), (-2, -31), (-2, -24), (-2, -21), (-1, -31),
    (-1, -30), (-1, -21), (0, -31), (0, -23), (0, -22), (0, -21), (0, -20), (1, -22), (1, -21),
    (2, -23), (2, -22), (2, -21), (2, -20), (12, -6), (12, -5), (13, -6), (13, -5), (15, -6),
    (15, -4), (15, 7), (16, -8), (16, -7), (16, -6), (16, -4), (16, 6), (16, 7), (16, 8), (17, -8),
    (17, -7), (17, -5), (17, -4), (18, -8), (18, -7), (18, -4), (18, 6), (18, 7), (19, -8),
    (20, -8), (21, -8), (21, 6), (22, -8), (24, 7), (24, 8), (25, 6), (25, 15), (26, 4), (26, 5),
    (26, 6), (26, 14), (26, 15), (26, 16), (27, 14), (28, 16), (29, 16), (34, -7), (35, -12),
    (35, -11), (35, -10), (35, -9), (35, -8), (35, -7), (36, -13), (36, -7), (37, -7), (38, -6),
    (39, -6), (40, -6)
]


def test_turns_round_in_a_dead_end_with_the_goal_beyond_it(footprint):
    """Field failure (multi-robot crossing, about 1 run in 2): robot_0 had driven into a
    dead-end pocket when its new plan came back out of the pocket's mouth, behind it, and
    round the chairs to the goal, 2.5 m away beyond them. The whole plan lay in the local
    costmap, so DWA scored every trajectory at its closest approach to the goal along the
    plan: for a robot facing away from its plan that is the trajectory's start, so every
    sample got the same path and goal costs, and was checked for collisions only over its
    braking distance. The robot spun on the spot, or crept nose first into the chairs and
    dithered there, until move_base aborted. Now only a trajectory that gets to the goal is
    scored at its closest approach, the others at their end (plain DWA): the robot turns
    round and drives out along its plan."""
    from my_summit_path_planning.navfn import resample_path
    res, frac = 0.05, (0.895, 0.869)
    m = recorded_costmap(footprint, POCKET_CELLS)
    x0, y0 = -3.5 + (70 + frac[0]) * res, -3.5 + (70 + frac[1]) * res
    pose = (x0, y0, 1.8187)                     # facing north-north-west, into the pocket
    plan = resample_path(np.array([(0.01, -0.05), (0.15, -0.51), (0.48, -0.81), (0.84, -1.07), (1.25, -1.22),
                                   (1.7, -1.26), (2.12, -1.15), (2.47, -0.88), (2.63, -0.48), (2.72, -0.07),
                                   (2.71, 0.38), (2.48, 0.72)]) + (x0, y0), 0.025)
    # The crossing's DWA parameters (dwa_local_planner_params.yaml, max_vel_x 0.6).
    cfg = DWAConfig(**dict(CFG, max_vel_x=0.6, max_vel_trans=0.6, xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, footprint)
    planner.set_plan(plan, 3.1539)
    clear = clearance_of(planner, m)
    left = np.concatenate([np.cumsum(np.hypot(*np.diff(plan, axis=0).T)[::-1])[::-1], [0.0]])

    def to_go(p):
        """Plan length left from the plan point nearest p, plus the distance to it [m]."""
        d = np.hypot(plan[:, 0] - p[0], plan[:, 1] - p[1])
        return float(left[np.argmin(d)] + d.min())
    c0, start = clear(pose), to_go(pose)
    vel, results, turned, best = (0.0, 0.0, 0.0), [], 0.0, start
    for _ in range(200):                        # 10 s
        r = planner.compute_velocity(pose, vel, m)
        results.append(r)
        vel = r.cmd                             # (0, 0, 0) when not ok, as move_base stops the robot
        pose = advance(pose, vel)
        turned += abs(vel[2]) * 0.05
        best = min(best, to_go(pose))
        assert clear(pose) >= min(c0, 0.0) - 0.01 - 1e-3
    failed = [res.reason for res in results if not res.ok]
    assert len(failed) <= 10, failed[:2]
    assert start - best > 1.5, (start, best, pose)   # out of the pocket and round the chairs
    assert turned < 2.0 * math.pi                    # it turned round once, it did not spin


# The local costmap in willow-full exploration (bench_explore.py --world willow --seed 1, t 279 s),
# cells (dx, dy) from the robot's cell as the laser marked them: the robot, heading 65 deg,
# has turned into a doorway that leads north between furniture, 0.35-0.5 m from its corners.
DOORWAY_CELLS = [
    (-30, -17), (-30, 6), (-29, -18), (-29, -17), (-29, 4), (-29, 6), (-29, 7), (-28, -18),
    (-28, 4), (-28, 6), (-27, 6), (-27, 7), (-26, 5), (-26, 7), (-25, 5), (-25, 7), (-24, 8),
    (-23, 6), (-23, 7), (-23, 8), (-23, 20), (-22, -23), (-22, 7), (-22, 8), (-22, 19), (-22, 20),
    (-21, -24), (-21, -23), (-21, -22), (-21, 5), (-21, 7), (-21, 8), (-21, 17), (-21, 18),
    (-21, 19), (-21, 20), (-21, 21), (-20, -25), (-20, -24), (-20, -23), (-20, -22), (-20, 7),
    (-20, 8), (-20, 9), (-20, 17), (-20, 18), (-20, 19), (-20, 20), (-20, 21), (-19, -28),
    (-19, -25), (-19, -24), (-19, 6), (-19, 8), (-19, 9), (-19, 18), (-19, 19), (-19, 20),
    (-19, 21), (-19, 22), (-19, 23), (-18, -30), (-18, -29), (-18, -28), (-18, -27), (-18, -24),
    (-18, -23), (-18, 6), (-18, 8), (-18, 9), (-18, 10), (-18, 20), (-18, 21), (-18, 22),
    (-17, -30), (-17, -29), (-17, -24), (-17, -23), (-17, 7), (-17, 8), (-17, 9), (-17, 10),
    (-17, 11), (-17, 12), (-17, 13), (-16, 7), (-16, 8), (-16, 9), (-16, 10), (-16, 20), (-15, 7),
    (-15, 8), (-15, 20), (-15, 21), (-15, 30), (-14, 20), (-14, 21), (-14, 22), (-14, 28),
    (-14, 29), (-13, 25), (-13, 26), (-12, 6), (-12, 23), (-12, 25), (-12, 26), (-12, 27), (-11, 4),
    (-11, 5), (-11, 6), (-11, 7), (-11, 20), (-11, 21), (-11, 22), (-11, 23), (-11, 24), (-11, 25),
    (-11, 26), (-11, 27), (-10, 4), (-10, 5), (-10, 6), (-10, 7), (-10, 18), (-10, 19), (-10, 21),
    (-10, 22), (-10, 23), (-10, 24), (-10, 25), (-10, 28), (-9, 5), (-9, 6), (-9, 7), (-9, 8),
    (-9, 9), (-9, 15), (-9, 16), (-9, 17), (-9, 18), (-9, 19), (-9, 20), (-9, 21), (-9, 23),
    (-9, 24), (-9, 25), (-9, 26), (-9, 27), (-8, 5), (-8, 6), (-8, 7), (-8, 8), (-8, 16), (-8, 17),
    (-8, 18), (-7, 5), (-7, 6), (-7, 16), (6, 30), (7, 27), (7, 28), (7, 29), (7, 30), (8, 7),
    (8, 25), (8, 26), (8, 27), (8, 28), (9, 5), (9, 6), (9, 7), (9, 8), (9, 22), (9, 23), (9, 24),
    (9, 25), (9, 26), (10, 2), (10, 3), (10, 4), (10, 5), (10, 6), (10, 7), (10, 8), (10, 9),
    (10, 10), (10, 19), (10, 20), (10, 21), (10, 22), (10, 23), (11, -21), (11, 2), (11, 3),
    (11, 4), (11, 8), (11, 9), (11, 10), (11, 16), (11, 17), (11, 18), (11, 19), (11, 20), (11, 21),
    (12, -22), (12, -21), (12, 9), (12, 10), (12, 14), (12, 15), (12, 16), (12, 17), (12, 18),
    (13, -22), (13, -21), (13, 11), (13, 12), (13, 13), (13, 14), (13, 15), (13, 16), (14, -21),
    (14, -20), (14, 13), (15, -21), (15, -20), (15, -15), (15, -14), (15, -13), (16, -15),
    (16, -14), (16, -13), (16, 5), (17, -15), (17, -14), (17, -13), (17, -12), (18, -13), (18, -12),
    (18, -1), (18, 0), (18, 1), (19, -13), (19, -12), (19, -4), (19, -3), (19, -2), (19, -1),
    (19, 0), (19, 1), (20, -12), (20, -6), (20, -5), (20, -4), (20, -3), (20, -2), (20, 1),
    (21, -9), (21, -8), (21, -7), (21, -6), (21, -5), (21, -4), (22, -11), (22, -10), (22, -9),
    (22, -8), (22, -7), (23, -14), (23, -13), (23, -12), (23, -11), (23, -10), (23, -9), (24, -15),
    (24, -14), (24, -13), (24, -12), (28, -18), (28, -17), (29, -19), (29, -18), (29, -17),
    (30, -22), (30, -21), (30, -20)
]


def test_creeps_out_of_a_doorway_it_is_wedged_in(footprint):
    """Field failure (willow-full exploration, from seed 1's start): the robot stood in a
    doorway between furniture, its footprint 3 mm from the marked cells, its plan turning
    north through the doorway. Every constant-velocity arc, checked over the whole horizon
    (1.9 s), lost more than ESCAPE_TOL of clearance somewhere, so escape mode found no
    valid command (of 587 samples 587 collide) for minutes and the explore goals were
    blacklisted one by one. Now a slow forward or turning command is admissible when the
    robot can stop before it loses clearance (Fox et al.'s admissible velocities): it
    creeps round into the doorway and half a metre along it, never cutting into the marked
    cells by more than the escape tolerance. (Where the doorway narrows further on it
    dithers again, turning one way and the other: not solved here.)"""
    from my_summit_path_planning.navfn import resample_path
    res, frac = 0.05, (0.228, 0.626)
    m = recorded_costmap(footprint, DOORWAY_CELLS)
    x0, y0 = -3.5 + (70 + frac[0]) * res, -3.5 + (70 + frac[1]) * res
    pose = (x0, y0, 1.1281)
    plan = resample_path(np.array([(0.02, 0.0), (0.04, 0.4), (0.08, 0.79), (0.0, 1.18), (-0.06, 1.55),
                                   (-0.16, 1.92), (0.07, 2.23), (0.46, 2.3), (0.65, 2.24)]) + (x0, y0), 0.025)
    # Exploration's DWA parameters (navigate_while_mapping.launch: max_vel_x 0.6, max_vel_theta 1.0).
    cfg = DWAConfig(**dict(CFG, max_vel_x=0.6, max_vel_trans=0.6, max_vel_theta=1.0, goal_distance_bias=20.0,
                           xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, footprint)
    planner.set_plan(plan, math.atan2(*(plan[-1] - plan[-2])[::-1]))
    clear = clearance_of(planner, m)
    c0 = clear(pose)
    assert 0.0 <= c0 < 0.005                    # wedged: 3 mm from the marked cells
    vel, start, failed = (0.101, 0.0, 0.262), pose, 0
    for _ in range(300):                        # 15 s
        r = planner.compute_velocity(pose, vel, m)
        if r.goal_reached:
            break
        # failed cycles on the way in (where the doorway narrows it dithers, see above)
        failed += not r.ok and pose[1] - start[1] < 0.4
        vel = r.cmd                             # (0, 0, 0) when not ok, as move_base stops the robot
        pose = advance(pose, vel)
        assert clear(pose) >= min(c0, 0.0) - ESCAPE_TOL - 1e-3
    assert failed <= 20, failed                 # (130 before)
    assert pose[1] - start[1] > 0.4, pose       # into the doorway, north (0.07 m before)
def test_backs_up_and_turns_round_between_furniture(footprint):
    """Field failure (willow-full exploration from seed 0's start, data_furniture_wedge.yaml):
    nose first between furniture, its plan leading away behind it, DWA turned the robot left
    and right in place, each turn blocked a few tenths of a radian on (DWA scores
    constant-velocity arcs: it cannot plan the three-point turn), and rotate_recovery found
    that turning would hit. The back_up recovery (recovery.BackUpRecovery) drives it 0.3 m
    straight back over the way it came (its trail), checking the footprint behind; from
    there DWA turns round and follows the plan, never touching the marked cells.

    Since the forward point is measured against the plan ahead of the robot (scores), DWA
    alone turns round here too, the short way, in about 18 s: the forward point of a
    nose turned away from the plan no longer scores the same whichever way it turns."""
    import os

    import yaml

    from my_summit_path_planning.navfn import resample_path
    from my_summit_path_planning.recovery import BackUpRecovery
    with open(os.path.join(os.path.dirname(__file__), "data_furniture_wedge.yaml")) as f:
        case = yaml.safe_load(f)
    res, frac = 0.05, case["frac"]
    m = recorded_costmap(footprint, [tuple(c) for c in case["cells"]])
    x0, y0 = -3.5 + (70 + frac[0]) * res, -3.5 + (70 + frac[1]) * res
    wedged = (x0, y0, case["yaw"])
    plan = resample_path(np.array(case["plan"]) + (x0, y0), 0.025)
    cfg = DWAConfig(**dict(CFG, max_vel_x=0.6, max_vel_trans=0.6, max_vel_theta=1.0, goal_distance_bias=20.0,
                           xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    clear = clearance_of(DWAPlanner(cfg, footprint), m)

    def drive(pose, vel, steps=300):            # 15 s of a fresh DWA, as move_base runs it
        planner = DWAPlanner(cfg, footprint)
        planner.set_plan(plan, math.atan2(*(plan[-1] - plan[-2])[::-1]))
        for _ in range(steps):
            r = planner.compute_velocity(pose, vel, m)
            if r.goal_reached:
                break
            vel = r.cmd
            pose = advance(pose, vel)
            assert clear(pose) >= -ESCAPE_TOL - 1e-3 and not footprint_hits(m, footprint, *pose)
        return pose

    # DWA alone: out and along the plan to its end within 20 s.
    p = drive(wedged, tuple(case["velocity"]), steps=400)
    assert math.hypot(p[0] - plan[-1][0], p[1] - plan[-1][1]) < 0.3, p
    # back_up, then DWA.
    rec = BackUpRecovery(footprint, frequency=20.0, acc_lim_x=cfg.acc_lim_x)
    rec.start(wedged, trail=[(x0 + dx, y0 + dy) for dx, dy in case["trail"]])   # the way it came
    p, vel = wedged, (0.0, 0.0, 0.0)
    for _ in range(400):
        step = rec.step(p, vel, m)
        if step.done:
            break
        assert step.cmd[0] < 0.0 and step.cmd[2] == 0.0
        vel = step.cmd
        p = advance(p, vel)
        assert not footprint_hits(m, footprint, *p)
    assert step.done and step.ok and rec.travelled(p) == pytest.approx(0.3, abs=0.02), (step, p)
    p = drive(p, (0.0, 0.0, 0.0))
    assert math.hypot(p[0] - plan[-1][0], p[1] - plan[-1][1]) < 0.3, p   # along the plan to its end, 3 m on


def test_latency_meter_longest_recent_interval():
    m = LatencyMeter(window=3, pause=2.0)
    assert m.update(0.0) is None                      # one cycle: no interval yet
    assert m.update(0.05) == pytest.approx(0.05)
    assert m.update(0.45) == pytest.approx(0.40)      # a late cycle
    m.update(0.50)
    m.update(0.55)
    assert m.update(0.60) == pytest.approx(0.05)      # the late one left the window
    assert m.update(5.0) == pytest.approx(0.05)       # a pause is not latency
    m.reset()
    assert m.update(5.05) is None


def test_planner_and_costmap_pickle_for_an_offline_replay(footprint):
    """move_base's ~debug_dump_dir pickles the planner (plan, oscillation and escape state)
    and the local costmap when DWA finds no command; the copy must plan as the original."""
    import copy
    import pickle
    walls = [(-3.5, 0.6, 3.5, 0.7), (-3.5, -0.7, 3.5, -0.6)]
    m = local_costmap(footprint, walls)
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    planner.set_plan(np.column_stack([np.linspace(-2.0, 3.0, 101), np.zeros(101)]), 0.0)
    poses, results = run(planner, m, footprint, (-2.0, 0.05, 0.1), steps=5)
    state = pickle.loads(pickle.dumps(copy.deepcopy({"dwa": planner, "costmap": m})))
    vel = results[-1].cmd
    a = planner.compute_velocity(poses[-1], vel, m)
    b = state["dwa"].compute_velocity(poses[-1], vel, state["costmap"])
    assert a.ok and b.ok and a.cmd == b.cmd


def test_a_planner_dumped_by_an_older_version_still_plans(footprint):
    """A debug dump from before DWAPlanner.policy (the ClearancePolicy), with state since
    dropped (_debug, rotating_to_goal), unpickles into a planner that plans as a new one."""
    import pickle
    m = local_costmap(footprint, [(-3.5, 0.30, 3.5, 0.45)])     # inscribed: escape mode
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    planner.set_plan(np.column_stack([np.linspace(0.0, 3.0, 61), np.full(61, -0.6)]), 0.0)
    old = pickle.loads(pickle.dumps(planner))
    del old.__dict__["policy"]
    old._debug, old.rotating_to_goal = {}, True
    replayed = pickle.loads(pickle.dumps(old))
    assert replayed.policy == planner.policy and not hasattr(replayed, "rotating_to_goal")
    a = planner.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    b = replayed.compute_velocity((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), m)
    assert a.ok and a.mode == "escape" and (b.cmd, b.mode) == (a.cmd, a.mode)


def test_replay_script_reads_a_dump_and_draws_it(footprint, tmp_path):
    """scripts/replay_dwa_dump.py on a dump of a robot boxed in by walls: it finds what the
    planner found live (escape mode, creeping forward) and draws the picture."""
    import os
    import pickle
    import subprocess
    import sys
    # boxed in: walls 4 cm from either side, front and back
    walls = [(-1.0, 0.45, 1.0, 0.55), (-1.0, -0.55, 1.0, -0.45), (0.40, -0.6, 0.5, 0.6), (-0.5, -0.6, -0.4, 0.6)]
    m = local_costmap(footprint, walls)
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    planner.set_plan(np.column_stack([np.linspace(0.0, 3.0, 61), np.zeros(61)]), 0.0)
    pose, vel = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    dump = tmp_path / "dwa_12.00.pkl"
    dump.write_bytes(pickle.dumps({"pose": pose, "velocity": vel, "dwa": planner, "costmap": m, "stamp": 12.0}))
    live = planner.compute_velocity(pose, vel, m)
    script = os.path.join(os.path.dirname(__file__), "..", "scripts", "replay_dwa_dump.py")
    png = tmp_path / "d.png"
    out = subprocess.run([sys.executable, script, str(dump), "--png", str(png), "--turn-around"],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert live.mode == "escape" and f"mode escape, ok {live.ok}, cmd {live.cmd}," in out.stdout
    assert "turn_around: no way out found" in out.stdout     # boxed in all round
    assert png.stat().st_size > 0
    bad = subprocess.run([sys.executable, script, str(tmp_path / "missing.pkl")], capture_output=True, text=True)
    assert bad.returncode == 2 and "cannot read" in bad.stderr


# The lethal cells (dx, dy) round the robot's cell in a move_base debug dump (willow-full
# exploration from seed 3's start, 128.8 s): a table end beside the robot's left side.
TABLE_END_CELLS = [
    (5, -7), (5, -5), (6, -11), (6, -10), (6, -9), (6, -8), (6, -7), (6, -6), (6, -5),
    (7, -17), (7, -11), (7, -10), (7, -9), (7, -8), (7, -7), (7, -6), (7, -5), (8, -25),
    (8, -24), (8, -23), (8, -22), (8, -19), (8, -18), (8, -17), (8, -6), (8, -5), (9, -30),
    (9, -29), (9, -27), (9, -26), (9, -25), (9, -24), (9, -23), (9, -17), (9, -16), (9, -6),
    (9, -5), (10, -30), (10, -29), (10, -23), (10, -6), (10, -5), (10, -4), (11, -16),
    (11, -15), (11, -14), (11, -6), (11, -5), (11, -4), (12, -16), (12, -15), (12, -6),
    (12, -5), (12, -4), (13, -27), (13, -26), (13, -6), (13, -5), (13, -4), (14, -5), (14, -4),
    (14, 16), (14, 17), (14, 18), (15, -26), (15, -5), (15, -4), (15, 15), (15, 16), (15, 17),
    (15, 18), (16, -26), (16, -24), (16, -23), (16, -22), (16, -5), (16, -4), (16, 15),
    (16, 16), (17, -26), (17, -25), (17, -24), (17, -23), (17, -22), (17, -5), (17, -4),
    (17, -3), (17, 16), (18, -22), (18, -5), (18, -4), (18, -3), (18, 15), (18, 16), (18, 17),
    (18, 18), (18, 19), (19, -5), (19, -4), (19, -3), (19, 13), (19, 14), (19, 15), (19, 16),
    (19, 17), (19, 18), (19, 19), (20, -5), (20, -4), (20, -3), (20, 14), (20, 15), (20, 18),
    (20, 19), (21, -4), (21, -3), (21, 13), (21, 14), (21, 18), (21, 19), (22, 14), (22, 15),
    (23, 14), (23, 15), (24, 14), (24, 15), (25, 14), (26, 17), (26, 18), (26, 19), (27, 14),
    (27, 15), (27, 16), (27, 19), (27, 20), (28, 14), (28, 15), (28, 19), (28, 20), (29, 15),
    (29, 19), (29, 20)
]


def test_escape_mode_moves_a_robot_whose_clearance_is_below_the_floor(footprint):
    """Field failure, replayed from a move_base debug dump (replay_dwa_dump.py): the robot
    stood past its footprint_padding (0.02 m) beside a table, clearance -0.025 m, while
    escape mode's floor (-0.0207 m, from earlier cycles) allowed no lower than -0.0217 m.
    The floor was reset only once the clearance had fallen ESCAPE_TOL below it, so every
    sample, starting below the limit, "would lose clearance" (166 of 166), recoveries
    could not move it either, and exploration ended "the robot is stuck" (56% of the
    building). Now the floor starts over from the robot's clearance: it turns away from
    the table and drives on along the plan, losing at most ESCAPE_SLACK on the way. The
    floor starts over with no slack to spend (ClearancePolicy.escape_floor): the
    trajectories are simulated at constant velocity while the robot ramps up to it, so
    its own motion can fall a few millimetres short of what was checked, and with a
    fresh ESCAPE_TOL after each such reset it crept ever deeper (2.4 cm in a replay of a
    willow-full wedge)."""
    from my_summit_path_planning.costmap import Footprint
    from my_summit_path_planning.clearance import ESCAPE_SLACK
    from my_summit_path_planning.navfn import resample_path
    padded = Footprint.from_params(footprint.polygon.tolist(), padding=0.02)   # explore.launch's
    res = 0.05
    m = recorded_costmap(padded, TABLE_END_CELLS)
    x0, y0 = -3.5 + (70 + 0.667) * res, -3.5 + (70 + 0.215) * res
    pose = (x0, y0, -2.2813)
    plan = resample_path(np.array([(0.0, 0.0), (-0.2, -0.08), (-0.36, -0.18), (-0.42, -0.37), (-0.44, -0.57),
                                   (-0.4, -0.96), (-0.35, -1.36), (-0.31, -1.75), (-0.26, -2.15)]) + (x0, y0), 0.025)
    cfg = DWAConfig(**dict(CFG, max_vel_x=0.6, max_vel_trans=0.6, max_vel_theta=1.0, goal_distance_bias=20.0,
                           xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, padded)
    planner.set_plan(plan, -1.45)
    planner._escape_floor = -0.0207            # as recorded
    clear = clearance_of(planner, m)
    c0 = clear(pose)
    assert -0.026 < c0 < -0.024                 # past the padding, below the floor's limit
    first = planner.compute_velocity(pose, (0.0, 0.0, 0.0), m)
    assert first.ok and first.mode == "escape", first.reason
    vel, lowest = (0.0, 0.0, 0.0), c0
    for _ in range(40):                         # 2 s
        r = planner.compute_velocity(pose, vel, m)
        vel = r.cmd
        pose = advance(pose, vel)
        lowest = min(lowest, clear(pose))
    assert lowest >= c0 - ESCAPE_SLACK - 1e-3
    assert clear(pose) > 0.1                    # out in the open
    assert math.hypot(pose[0] - x0, pose[1] - y0) > 0.5, pose


# The lethal cells (dx, dy) round the robot's cell in a move_base debug dump (willow-full
# exploration from seed 0's start, 1047.3 s): a dead-end pocket between a wall along the
# robot's left side, a wall a hand's width behind its tail and a table leg ahead.
TABLE_POCKET_CELLS = [
    (-25, -2), (-25, -1), (-24, -15), (-24, -14), (-24, -4), (-24, -3), (-24, -2), (-23,
    -16), (-23, -15), (-23, -14), (-23, -4), (-23, -3), (-23, -2), (-22, -16), (-22, -15),
    (-22, -14), (-18, 26), (-18, 27), (-17, 15), (-17, 16), (-17, 25), (-17, 26), (-17, 27),
    (-17, 28), (-16, 15), (-16, 16), (-16, 17), (-16, 26), (-16, 27), (-16, 28), (-16, 29),
    (-15, 15), (-15, 16), (-15, 17), (-15, 28), (-15, 29), (-14, 29), (-12, 18), (-12, 19),
    (-11, 16), (-11, 20), (-10, 16), (-10, 20), (-9, -8), (-9, -7), (-9, -6), (-9, -5), (-9,
    13), (-9, 14), (-9, 18), (-8, -9), (-8, -8), (-8, -7), (-8, -6), (-8, -5), (-8, 11),
    (-8, 14), (-8, 16), (-7, -5), (-7, 11), (-7, 12), (-7, 13), (-7, 15), (-6, 10), (-6,
    11), (-6, 12), (-6, 13), (-5, 12), (-5, 13), (-5, 14), (-4, 12), (-4, 13), (-4, 14),
    (-3, 12), (-3, 13), (-3, 14), (-2, 11), (-2, 12), (-2, 13), (-2, 14), (-1, 11), (-1,
    12), (-1, 13), (-1, 14), (0, 11), (0, 12), (0, 13), (2, 10), (2, 11), (3, 10), (3, 11),
    (3, 12), (3, 13), (4, 10), (4, 11), (4, 12), (5, 10), (5, 11), (5, 12), (6, 9), (6, 10),
    (6, 11), (7, 9), (7, 10), (7, 11), (8, 9), (8, 10), (8, 11), (9, 9), (9, 10), (9, 11),
    (10, 9), (10, 10), (10, 11), (11, -10), (11, -4), (11, -3), (11, -2), (11, 9), (11, 10),
    (12, -10), (12, -9), (12, -8), (12, -7), (12, -3), (12, -2), (12, -1), (12, 0), (12, 1),
    (12, 8), (12, 9), (13, -12), (13, -9), (13, -8), (13, -7), (13, -6), (13, -5), (13, -1),
    (13, 0), (13, 1), (13, 2), (13, 3), (13, 4), (13, 5), (13, 6), (14, -15), (14, -14),
    (14, -12), (14, -10), (14, -5), (14, 2), (14, 3), (14, 4), (14, 5), (14, 6), (14, 7),
    (14, 8), (15, -17), (15, -15), (15, -14), (15, -13), (15, 6), (15, 7), (15, 10), (15,
    11), (15, 12), (16, -17), (16, -16), (16, -15), (16, 9), (16, 10), (16, 11), (16, 12),
    (17, -20), (17, -19), (17, 9), (17, 10), (18, -18), (18, 9), (18, 10), (19, -30), (19,
    -20), (19, 9), (20, -30), (20, -20), (21, -30), (21, -22), (21, -21), (22, -30), (22,
    -29), (22, -23), (23, -30), (23, -29), (23, -28), (23, -27), (24, -28), (24, -27), (24,
    -26), (24, -25), (24, -24), (24, -23), (24, -22), (24, -21), (24, -14), (24, -13), (25,
    -24), (25, -22), (25, -21), (25, -20), (25, -11), (25, -10), (26, -21), (26, -14), (27,
    -15), (27, -14), (27, -13), (27, -12), (27, -11), (27, -10), (28, -14), (28, -13), (28,
    -9), (28, -8), (28, -7), (29, -10), (29, -6)
]


def test_turn_around_recovery_drives_out_of_a_dead_end_pocket(footprint):
    """Field failure (willow-full exploration, seed 0): the robot followed its plan into a
    pocket and the plan then moved behind it. DWA found no command ("of 166 samples 166
    collide"; now it creeps back a little, then finds none), back_up got 4 cm and
    rotate_recovery found that turning would hit, and
    explore gave up goals until "the robot is stuck" (65% of the building). turn_around
    searches shunting moves out of it and drives them (a robot ramping its speed up and
    down), going into footprint_padding but keeping 5 mm of it; from where it ends up, DWA
    drives on along the plan."""
    from my_summit_path_planning.costmap import Footprint
    from my_summit_path_planning.navfn import resample_path
    from my_summit_path_planning.recovery import manoeuvre_limit, plan_manoeuvre
    padded = Footprint.from_params(footprint.polygon.tolist(), padding=0.02)   # explore.launch's
    res = 0.05
    m = recorded_costmap(padded, TABLE_POCKET_CELLS)
    x0, y0 = -3.5 + (70 + 0.452) * res, -3.5 + (70 + 0.552) * res
    pose = (x0, y0, 2.538)
    plan = resample_path(np.array([(0.0, 0.0), (0.09, -0.17), (0.08, -0.37), (0.07, -0.57), (0.06, -0.77),
                                   (0.05, -0.97), (0.11, -1.16), (0.18, -1.35), (0.28, -1.52), (0.4, -1.68)])
                         + (x0, y0), 0.025)
    cfg = DWAConfig(**dict(CFG, max_vel_x=0.6, max_vel_trans=0.6, max_vel_theta=1.0, goal_distance_bias=20.0,
                           xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, padded)
    planner.set_plan(plan, 1.744)
    clear = clearance_of(planner, m)
    c0 = clear(pose)
    assert 0.0 < c0 < 0.01
    # DWA alone: a few centimetres of creeping back, then nothing (as move_base stops the
    # robot when there is no command, and plans again every 2 s, as explore.launch)
    p, vel = pose, (0.0, 0.0, 0.0)
    for i in range(200):                        # 10 s
        if i % 40 == 39:
            planner.set_plan(plan, 1.744)
        r = planner.compute_velocity(p, vel, m)
        vel = r.cmd
        p = advance(p, vel)
    assert math.hypot(p[0] - x0, p[1] - y0) < 0.1, p

    assert plan_manoeuvre(padded, m, pose, keep=0.02) is None     # no way out within the padding
    s, pose, lowest = drive_turn_around(padded, pose, m, clear)
    assert s.done and s.ok, s.reason
    assert lowest >= manoeuvre_limit(c0, padded.padding, 0.005) - 2e-3   # 5 mm of the padding kept
    assert math.hypot(pose[0] - x0, pose[1] - y0) >= 0.2
    assert clear(pose) >= c0 + 0.01
    planner.set_plan(plan, 1.744)               # move_base plans again after a recovery
    poses, results = [pose], []
    vel = (0.0, 0.0, 0.0)
    for _ in range(200):                        # 10 s of DWA
        r = planner.compute_velocity(pose, vel, m)
        results.append(r.ok)
        vel = r.cmd
        pose = advance(pose, vel)
        lowest = min(lowest, clear(pose))
    assert sum(results) >= 190, sum(results)
    assert lowest >= manoeuvre_limit(c0, padded.padding, 0.005) - 2e-3
    assert pose[1] < y0 - 0.8, pose            # down the plan, out of the pocket


def test_creeps_back_out_of_a_pocket_no_backward_arc_clears(footprint):
    """Field failure (willow-full exploration, seed 0, 1047 s, the same dump as above): in
    a dead-end pocket with its plan behind it, a wall along the robot's left side, another
    a hand's width behind its tail and a table leg ahead, no arc backwards stayed clear
    over the whole horizon, though a few centimetres back and to the right let it turn:
    "of 166 samples 166 collide" for 260 s, and explore ended "the robot is stuck". Now,
    boxed in, escape mode admits a slow reversing move that regains clearance by the time
    the robot could stop (ClearancePolicy.creep_back) and touches nothing on the way: DWA
    creeps back, a cycle at a time (the way out of this pocket is turn_around's, above)."""
    from my_summit_path_planning.costmap import Footprint
    from my_summit_path_planning.navfn import resample_path
    padded = Footprint.from_params(footprint.polygon.tolist(), padding=0.02)   # explore.launch's
    res = 0.05
    m = recorded_costmap(padded, TABLE_POCKET_CELLS)
    x0, y0 = -3.5 + (70 + 0.452) * res, -3.5 + (70 + 0.552) * res
    pose = (x0, y0, 2.538)
    plan = resample_path(np.array([(0.0, 0.0), (0.09, -0.17), (0.08, -0.37), (0.07, -0.57), (0.06, -0.77),
                                   (0.05, -0.97), (0.11, -1.16), (0.18, -1.35), (0.28, -1.52), (0.4, -1.68)])
                         + (x0, y0), 0.025)
    cfg = DWAConfig(**dict(CFG, max_vel_x=0.6, max_vel_trans=0.6, max_vel_theta=1.0, goal_distance_bias=20.0,
                           xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, padded)
    planner.set_plan(plan, 1.744)
    clear = clearance_of(planner, m)
    c0 = clear(pose)
    r = planner.compute_velocity(pose, (0.0, 0.0, 0.0), m)
    assert r.ok and r.mode == "escape", r.reason
    assert r.cmd[0] < 0.0 and r.n_valid <= 10          # creeping back, the last resort
    assert clear(advance(pose, r.cmd)) >= c0            # regaining clearance


# The lethal cells (dx, dy) round the robot's cell in a move_base debug dump (willow-full
# exploration from seed 1's start, 265.1 s): a channel between two clusters of chair and
# table legs, as wide as the padded footprint give or take a centimetre.
LEG_CHANNEL_CELLS = [
    (-30, 12), (-30, 13), (-30, 14), (-30, 15), (-30, 16), (-30, 19), (-30, 20), (-29,
    14), (-29, 15), (-26, 17), (-24, 14), (-24, 15), (-23, 14), (-23, 15), (-22, 15),
    (-21, 15), (-20, 17), (-20, 18), (-19, 14), (-16, 10), (-16, 11), (-16, 12), (-15,
    11), (-15, 12), (-14, 12), (-14, 18), (-13, 12), (-13, 17), (-13, 18), (-13, 19),
    (-12, 11), (-12, 18), (-12, 19), (-11, 11), (-11, 18), (-11, 19), (-11, 20), (-11,
    21), (-11, 22), (-10, 11), (-10, 13), (-10, 14), (-10, 15), (-10, 19), (-10, 20),
    (-10, 21), (-10, 22), (-10, 23), (-9, 7), (-9, 13), (-9, 14), (-9, 21), (-9, 22),
    (-9, 24), (-9, 25), (-8, 7), (-8, 8), (-8, 22), (-8, 25), (-7, 7), (-7, 8), (-7, 9),
    (-7, 18), (-7, 19), (-6, 7), (-6, 8), (-6, 9), (-6, 10), (-6, 18), (-6, 19), (-6,
    20), (-6, 21), (-6, 22), (-5, 8), (-5, 9), (-5, 18), (-5, 19), (-5, 21), (-5, 22),
    (-5, 24), (-5, 25), (-4, 21), (-4, 23), (-4, 24), (-4, 25), (-4, 30), (-3, 24), (-3,
    30), (6, -18), (6, -5), (6, -4), (7, -18), (7, -6), (7, -5), (7, -4), (7, -2), (8,
    -17), (8, -5), (8, -4), (8, -3), (8, -2), (8, -1), (8, 0), (8, 1), (9, -4), (9, -3),
    (9, -2), (9, -1), (9, 0), (9, 1), (10, -2), (10, -1), (10, 0), (10, 1), (11, -5),
    (11, -4), (11, -1), (11, 1), (11, 2), (12, -7), (12, -6), (12, -5), (12, 0), (12,
    1), (12, 2), (13, -16), (13, -15), (13, -8), (13, -7), (13, -6), (13, 0), (13, 2),
    (14, -16), (14, -15), (14, -14), (14, -6), (14, 0), (15, -15), (15, -14), (15, -6),
    (16, -14), (16, -5), (16, 1), (16, 2), (17, -14), (17, -13), (17, -5), (17, 1), (17,
    2), (18, -14), (18, -13), (18, 1), (18, 2), (19, -2), (20, -1), (21, -3), (21, -2),
    (22, -3), (22, 3), (22, 4), (23, -2), (23, 2), (23, 3), (23, 4), (24, -2), (24, -1),
    (24, 3), (24, 4), (24, 5), (25, -3), (25, -2), (25, -1), (25, 4), (25, 5), (26, -4),
    (26, -3), (26, -2), (26, 4), (26, 5), (27, -3), (27, -2), (27, 5), (27, 6), (28, 5),
    (28, 6), (29, 6), (30, 0), (30, 1), (30, 6), (30, 7)]


def test_turn_around_spends_the_last_of_the_padding_only_when_nothing_else_gets_out(footprint):
    """Field failure (willow-full exploration, seed 1): new laser marks closed round the
    robot in a channel between chair and table legs, 2.5 mm inside its padded footprint.
    Straight back out the way it came the clearance dips to -1.6 cm for a centimetre (the
    footprint crossing cells), below what back_up, DWA's escape mode and a turn_around
    keeping 5 mm of footprint_padding allow, so every recovery failed, 6 goals were given
    up and explore ended "the robot is stuck" at 28%. turn_around now searches again
    keeping none of the padding when keeping 5 mm finds nothing, and drives out without
    the unpadded footprint touching a cell; DWA then drives on down the plan."""
    from my_summit_path_planning.costmap import Footprint
    from my_summit_path_planning.navfn import resample_path
    from my_summit_path_planning.recovery import plan_manoeuvre, search_manoeuvre
    padded = Footprint.from_params(footprint.polygon.tolist(), padding=0.02)   # explore.launch's
    res = 0.05
    m = recorded_costmap(padded, LEG_CHANNEL_CELLS)
    x0, y0 = -3.5 + (70 + 0.273) * res, -3.5 + (70 + 0.880) * res
    pose = (x0, y0, 1.155)
    plan = resample_path(np.array([[0.02, 0.01], [-0.1, -0.1], [-0.21, -0.23], [-0.32, -0.37], [-0.39, -0.53], [-0.42, -0.7], [-0.44, -0.87], [-0.4, -1.04], [-0.37, -1.21], [-0.28, -1.36]]) + (x0, y0), 0.025)
    cfg = DWAConfig(**dict(CFG, max_vel_x=0.6, max_vel_trans=0.6, max_vel_theta=1.0, goal_distance_bias=20.0,
                           xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, padded)
    planner.set_plan(plan, -1.6)
    clear = clearance_of(planner, m)
    c0 = clear(pose)
    assert -0.01 < c0 < 0.0
    assert not planner.compute_velocity(pose, (0.0, 0.0, 0.0), m).ok
    assert plan_manoeuvre(padded, m, pose, keep=0.005) is None                  # keeping 5 mm: no way
    assert plan_manoeuvre(padded, m, pose, keep=0.005, step=0.03, turn=0.06) is None
    moves, (_, _, kept) = search_manoeuvre(padded, m, pose)
    assert moves and kept == 0.0
    s, pose, lowest = drive_turn_around(padded, pose, m, clear,
                                        check=lambda p: not footprint_hits(m, footprint, *p))
    assert s.done and s.ok, s.reason
    assert lowest >= -padded.padding - 1e-3
    assert math.hypot(pose[0] - x0, pose[1] - y0) >= 0.25
    assert clear(pose) >= 0.0
    planner.set_plan(plan, -1.6)                # move_base plans again after a recovery
    vel = (0.0, 0.0, 0.0)
    for _ in range(200):                        # 10 s of DWA
        r = planner.compute_velocity(pose, vel, m)
        vel = r.cmd
        pose = advance(pose, vel)
        assert not footprint_hits(m, footprint, *pose), pose
    assert math.hypot(pose[0] - x0, pose[1] - y0) > 1.0, pose   # down the plan, out of the channel


# The lethal cells (dx, dy) round the robot's cell in a move_base debug dump (the
# get_coordinates rostest's drive from the hall spot 'near' back to 0 0 0, sim speed 2x on a
# loaded machine, 103.4 s): the arc of a hall pillar the laser saw, ahead-right of the robot.
HALL_PILLAR_CELLS = [
    (-13, 6), (-12, 5), (-12, 6), (-11, 5), (-11, 6), (-10, 5), (-10, 6), (-9, 5), (-9, 6), (-9, 7),
    (-8, 6), (-8, 7), (-7, 7), (-7, 8), (-7, 9), (-7, 12), (-7, 13), (-6, 7), (-6, 8), (-6, 9), (-5, 9)]
# Its global plan from the robot (every 0.25 m; it runs on 4.7 m, out of the local costmap).
HALL_PILLAR_PLAN = [
    (0.14, -0.24), (-0.1, -0.37), (-0.33, -0.46), (-0.58, -0.47), (-0.81, -0.4), (-1.02, -0.26),
    (-1.23, -0.12), (-1.44, 0.01), (-1.65, 0.15), (-1.86, 0.29), (-2.07, 0.42), (-2.27, 0.56),
    (-2.48, 0.69), (-2.69, 0.83), (-2.9, 0.97), (-3.11, 1.1), (-3.32, 1.24), (-3.53, 1.38),
    (-3.74, 1.51), (-3.89, 1.62)]


def test_passing_a_pillar_at_speed_inside_the_padding_drives_on(footprint):
    """Field failure (get_coordinates_bad_input rostest, known-flaky: 'stalled beside a hall
    pillar'), replayed from a move_base debug dump: driving round a pillar at 0.72 m/s
    with the control loop 0.34 s late (sim at 2x on a loaded machine), the robot found
    itself 8 mm inside its 1 cm footprint_padding (a late command had carried it past
    what the previous cycle checked), so DWA was in escape mode. Escape mode judged
    fast samples by their whole 1.9 s horizon, where every arc round the pillar dips
    0.5-1 mm below the escape limit 0.8 s ahead before opening up (only samples up to
    ESCAPE_VEL_X were judged by their braking distance), and the window of a robot at
    0.72 m/s holds none that slow: "of 800 samples 800 collide", move_base published
    zero and the robot braked along its arc, unchecked (in an offline closed loop from
    the dump, to 2 mm past the unpadded footprint, where escape mode allows no more loss
    to creep out). Recorded with move_base dumping every such cycle: in 1 drive of 4 from
    'near' back to 0 0 0 beside the pillar, each time passed after a cycle or two; the
    rostest's stall (DWA with no valid command beside the pillar until move_base gave
    up) was not caught in 40 drives, this is how it starts. Now a robot that is driving when it finds itself inside its
    padding is judged as one creeping out: by Fox et al.'s admissible velocities (the
    clearance until it could stop) at up to its present speed, never below the escape
    limit (the unpadded footprint). It drives on round the pillar, still with the late
    loop, never past the unpadded footprint, and every cycle has a command."""
    import os
    from my_summit_path_planning.costmap import Footprint
    from my_summit_path_planning.navfn import resample_path
    from my_summit_path_planning.params import load_move_base_params
    params = load_move_base_params(os.path.join(os.path.dirname(__file__), "..", "config"))
    padded = Footprint.from_params(footprint.polygon.tolist(), padding=0.01)   # the course's local costmap
    res, hold, dt = 0.05, 0.34, 0.01
    m = recorded_costmap(padded, HALL_PILLAR_CELLS)
    x0, y0 = -3.5 + (70 + 0.085) * res, -3.5 + (70 + 0.31) * res
    pose, vel = (x0, y0, -2.9471), (0.7224, 0.0, 0.6513)
    planner = DWAPlanner(params.dwa, padded)
    planner.set_plan(resample_path(np.array(HALL_PILLAR_PLAN) + (x0, y0), 0.025), -1.2962)
    planner.set_control_latency(hold)                        # as measured by move_base
    clear = clearance_of(planner, m)
    c0 = clear(pose)
    assert -0.009 < c0 < -0.007                              # inside the padding, as recorded
    first = planner.compute_velocity(pose, vel, m)
    assert first.ok and first.mode == "escape", first.reason
    lowest, start = c0, pose
    for _ in range(int(round(3.0 / hold))):                  # 3 s of the late loop
        r = planner.compute_velocity(pose, vel, m)
        assert r.ok, r.reason
        for _ in range(int(round(hold / dt))):               # the command in force, ramped to
            vx = vel[0] + float(np.clip(r.cmd[0] - vel[0], -2.5 * dt, 2.5 * dt))
            vth = vel[2] + float(np.clip(r.cmd[2] - vel[2], -5.0 * dt, 5.0 * dt))
            vel = (vx, 0.0, vth)
            pose = advance(pose, vel, dt)
            lowest = min(lowest, clear(pose))
    assert lowest >= -padded.padding - 1e-3                  # never past the unpadded footprint
    assert not footprint_hits(m, footprint, *pose)
    assert clear(pose) > 0.1                                 # past the pillar, in the open
    assert math.hypot(pose[0] - start[0], pose[1] - start[1]) > 1.0, pose


def _drive_with_block(monkeypatch, block_bytes, scene):
    from my_summit_path_planning import dwa
    monkeypatch.setattr(dwa, "BLOCK_BYTES", block_bytes)
    m, planner, pose, vel, steps, footprint = scene()
    out = []
    for _ in range(steps):
        r = planner.compute_velocity(pose, vel, m)
        out.append((r.ok, r.mode, r.cmd, r.n_valid, r.n_samples, r.cost, r.reason,
                    None if r.trajectory is None else r.trajectory.tobytes(), r.goal_reached))
        if r.goal_reached or not r.ok:
            break
        vel = r.cmd
        pose = advance(pose, vel, 0.05)
    return out


def _corridor(footprint):
    m = local_costmap(footprint, [(-3.5, 0.6, 3.5, 0.7), (-3.5, -0.7, 3.5, -0.6)])
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    planner.set_plan(np.column_stack([np.linspace(-2.0, 1.0, 61), np.zeros(61)]), 0.5)
    return m, planner, (-2.0, 0.05, 0.1), (0.0, 0.0, 0.0), 80, footprint


def _inscribed(footprint):
    m = local_costmap(footprint, [(-3.5, 0.30, 3.5, 0.45)])
    planner = DWAPlanner(DWAConfig(**CFG), footprint)
    planner.set_plan(np.column_stack([np.linspace(0.0, 3.0, 61), np.full(61, -0.6)]), 0.0)
    return m, planner, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 30, footprint


def _boxed_in(footprint):
    front, side = 0.36 + 0.27, 0.31 + 0.06
    m = local_costmap(footprint, [(-front - 0.3, -3.0, -front, 3.0), (-front, -side - 0.3, 1.5, -side)])
    cfg = DWAConfig(**dict(CFG, xy_goal_tolerance=0.10, yaw_goal_tolerance=0.06))
    planner = DWAPlanner(cfg, Footprint.from_params(footprint.oriented(0.0, 0.0, 0.0).tolist(), padding=0.01))
    from my_summit_path_planning.navfn import resample_path
    planner.set_plan(resample_path(np.array([(0.0, 0.0), (1.0, 0.3), (2.5, 0.6)]), 0.025), 0.0)
    return m, planner, (0.0, 0.0, math.pi), (0.0, 0.0, 0.0), 40, footprint


@pytest.mark.parametrize("scene", [_corridor, _inscribed, _boxed_in])
def test_samples_evaluated_in_blocks_decide_as_all_at_once(footprint, monkeypatch, scene):
    """DWA runs steps 3-5 on blocks of samples so that its arrays stay below glibc's mmap
    threshold (bench_stack_cpu at 2168d06: move_base took 129,000 minor page faults a
    second, its CPU per simulated second up from 0.42 to 0.64). Every step is per sample
    and escape mode's boxed-in fallback runs over all of them: one row per block, the
    default blocks and one block of all samples drive the same to the bit, through the
    ordinary mode up to the goal, escape mode and the boxed-in corner's fallback."""
    modes = {r[1] for r in _drive_with_block(monkeypatch, 1 << 40, lambda: scene(footprint))}
    assert modes & {"escape", "goal", "rotate"}, modes
    from my_summit_path_planning import dwa
    default = dwa.BLOCK_BYTES
    one_block = _drive_with_block(monkeypatch, 1 << 40, lambda: scene(footprint))
    assert len(one_block) > 5
    assert _drive_with_block(monkeypatch, 20000, lambda: scene(footprint)) == one_block   # ~30 rows a block
    assert _drive_with_block(monkeypatch, default, lambda: scene(footprint)) == one_block
