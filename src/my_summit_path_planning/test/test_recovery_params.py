"""Recoveries and the typed parameter configs."""
import math
import os
import re
import shutil

import numpy as np
import pytest
import yaml

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D, Footprint, LayeredCostmap
from my_summit_path_planning.clearance import ClearancePolicy
from my_summit_path_planning.layers import scan_to_observation
from my_summit_path_planning.params import ParamError, build_costmap, load_move_base_params
from my_summit_path_planning.nav_core import PluginContext
from my_summit_path_planning.plugins import default_recovery_sequence, recovery_sequence
from my_summit_path_planning.recovery import (BACKUP_TYPE, CLEAR_TYPE, ROTATE_TYPE, TURN_AROUND_TYPE,
                                              BackUpRecovery, ClearCostmapRecovery, RotateRecovery,
                                              TurnAroundRecovery, clear_costmap_layers, plan_manoeuvre,
                                              retrace_distance)

CONFIG = os.path.join(os.path.dirname(__file__), "..", "config")
SUMMIT_FOOTPRINT = [[0.36, 0.31], [-0.36, 0.31], [-0.36, -0.31], [0.36, -0.31]]


def _with_obstacles(footprint):
    lc = LayeredCostmap.from_plugins(
        [{"name": "obstacle_layer", "type": "costmap_2d::ObstacleLayer"}],
        {"obstacle_layer": {"observation_sources": "s", "s": {"clearing": True}, "obstacle_range": 10.0}},
        Costmap2D(200, 200, 0.05, -5.0, -5.0), footprint)
    ang = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    lc.layer("obstacle_layer").add_observation(
        scan_to_observation(np.where(np.abs(ang) < 0.3, 1.0, 4.0), -math.pi, ang[1] - ang[0], 0.1, 30.0, (0, 0, 0),
                            obstacle_range=10.0, raytrace_range=10.0))
    lc.update_map(0.0, 0.0, 0.0)
    return lc


def run_recovery(rec, pose, costmap, check=None, steps=400, dt=0.05):
    """Start rec at pose and drive a perfect robot (velocity = command) until it is done;
    check(pose) must hold at every pose. Returns (its last step, the pose)."""
    rec.start(pose)
    for _ in range(steps):
        step = rec.step(pose, (0, 0, 0), costmap)
        if step.done:
            break
        vx, _, w = step.cmd
        pose = (pose[0] + vx * math.cos(pose[2]) * dt, pose[1] + vx * math.sin(pose[2]) * dt, pose[2] + w * dt)
        assert check is None or check(pose), pose
    return step, pose


def test_conservative_and_aggressive_reset(footprint):
    lc = _with_obstacles(footprint)
    assert lc.master.cost_at(0.98, 0.0) == cv.LETHAL_OBSTACLE
    assert lc.master.cost_at(-4.0, 0.0) == cv.LETHAL_OBSTACLE
    assert clear_costmap_layers(lc, (0.0, 0.0), 3.0) == []   # the default layer_names: [obstacles]
    assert clear_costmap_layers(lc, (0.0, 0.0), 3.0, ("obstacle_layer",)) == ["obstacle_layer"]
    lc.update_map(0.0, 0.0, 0.0)
    assert lc.master.cost_at(0.98, 0.0) == cv.LETHAL_OBSTACLE     # inside the square: kept
    assert lc.master.cost_at(-4.0, 0.0) == cv.FREE_SPACE          # outside: cleared
    clear_costmap_layers(lc, (0.0, 0.0), 3.0, ("obstacle_layer",), force_clear_all=True)
    lc.update_map(0.0, 0.0, 0.0)
    assert (lc.master.data == cv.FREE_SPACE).all()



def test_rotate_recovery_sim_granularity_is_radians(footprint, monkeypatch):
    """rotate_recovery's ~sim_granularity is the angle between footprint checks (the wiki:
    "the distance in radians between checks", rotate_recovery.cpp steps the angle by it).
    Ours read it as metres of arc at the circumscribed radius: 0.017 became 0.037 rad
    for the Summit, and a user's value was stretched the same way."""
    import my_summit_path_planning.recovery as recovery
    seen = {}

    def spy(fp, costmap, pose, x, y, th, limit=None):
        seen["th"] = np.asarray(th)
        return True
    monkeypatch.setattr(recovery, "footprint_free", spy)
    free = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    for granularity in (0.017, 0.1):
        rec = RotateRecovery(footprint, sim_granularity=granularity)
        rec.start((0.0, 0.0, 0.0))
        assert rec.step((0.0, 0.0, 0.0), (0, 0, 0), free).ok
        steps = np.diff(np.concatenate([[0.0], seen["th"]]))
        assert steps.max() <= granularity + 1e-9 and steps.min() > 0.9 * granularity

def test_rotate_recovery_turns_once_and_stops_when_blocked(footprint):
    free = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    rec = RotateRecovery(footprint)
    step, pose = run_recovery(rec, (0.0, 0.0, 0.0), free)
    assert step.done and step.ok and pose[2] == pytest.approx(2.0 * math.pi, abs=0.1)
    blocked = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    blocked.data[50:56, 58:60] = cv.LETHAL_OBSTACLE  # touches the footprint's corner sweep only
    rec.start((0.0, 0.0, 0.0))
    assert not rec.step((0.0, 0.0, 0.0), (0, 0, 0), blocked).ok
    seq = default_recovery_sequence(PluginContext(footprint=footprint))
    assert [n for n, _ in seq] == ["conservative_reset", "rotate_recovery", "aggressive_reset", "rotate_recovery"]


def _trail_behind(pose, length=1.0):
    """Points every 2 cm along the straight line the robot came by (length [m] behind it)."""
    s = np.arange(0.0, length + 1e-9, 0.02)
    return list(zip(pose[0] - s * math.cos(pose[2]), pose[1] - s * math.sin(pose[2])))


def _back_up(rec, costmap, pose=(0.0, 0.0, 0.0), trail=None, steps=400, move=True):
    """Run a back_up recovery on a perfect robot that came straight to pose (unless a trail
    is given); returns (last step, pose)."""
    rec.start(pose, trail=_trail_behind(pose) if trail is None else trail)
    vel = (0.0, 0.0, 0.0)
    for _ in range(steps):
        step = rec.step(pose, vel, costmap)
        if step.done:
            return step, pose
        assert step.cmd[0] < 0.0 and step.cmd[1] == 0.0 and step.cmd[2] == 0.0
        vel = step.cmd
        if move:
            pose = (pose[0] + vel[0] * math.cos(pose[2]) * 0.05, pose[1] + vel[0] * math.sin(pose[2]) * 0.05, pose[2])
    return step, pose


def test_back_up_recovery_backs_up_and_stops_where_it_would_hit(footprint):
    free = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    step, pose = _back_up(BackUpRecovery(footprint, backup_dist=0.3, backup_speed=0.1), free, (0.0, 0.0, math.pi / 2))
    assert step.done and step.ok and re.fullmatch(r"backed up 0\.(29|30) m", step.reason), step.reason
    assert pose[0] == pytest.approx(0.0) and -0.31 < pose[1] < -0.28     # straight back (facing +y)
    # A wall 0.14 m behind the rear (x = -0.36): backs up to it and says so, ok.
    wall = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    wall.data[:, 39] = cv.LETHAL_OBSTACLE                                  # cells x in [-0.55, -0.50)
    step, pose = _back_up(BackUpRecovery(footprint), wall)
    assert step.done and step.ok and "backing up further would hit" in step.reason
    assert 0.02 < -pose[0] < 0.3 and not footprint_hits_costmap(wall, footprint, pose)
    # Against the wall already: does not move, not ok.
    step, _ = _back_up(BackUpRecovery(footprint), wall, (pose[0] - 0.02, 0.0, 0.0))
    assert step.done and not step.ok and "would hit" in step.reason
    # A robot that does not move (held by something the costmap lacks) gives up after
    # time_allowance.
    step, _ = _back_up(BackUpRecovery(footprint, time_allowance=2.0, frequency=20.0), free, move=False)
    assert step.done and not step.ok and "in 2 s" in step.reason
    with pytest.raises(ValueError, match="backup_dist"):
        BackUpRecovery(footprint, backup_dist=-0.3)


def test_recoveries_move_a_robot_left_inside_its_padding(footprint):
    """DWA's escape mode may leave the robot inside footprint_padding (clearance < 0, the
    real body a centimetre from a wall): back_up and rotate_recovery still move it, as far
    as the escape limit (never past the unpadded body's edge). Held to clearance >= 0,
    back_up stopped at once and the robot was stuck (willow-full exploration)."""
    padded = Footprint.from_params(SUMMIT_FOOTPRINT, padding=0.02)
    pad2, pad0 = ClearancePolicy(0.02), ClearancePolicy(0.0)
    assert pad2.escape(0.0) == pytest.approx(-0.01)       # ESCAPE_TOL below the floor
    assert pad2.escape(-0.015) == pytest.approx(-0.02)    # not past the unpadded edge
    assert pad2.escape(-0.03) == pytest.approx(-0.031)    # already past it: ESCAPE_SLACK
    assert pad0.escape(-0.005) == pytest.approx(-0.015)   # no padding: no margin kept
    assert pad2.recovery(0.03) == 0.0 and pad0.recovery(0.0) == pytest.approx(-0.001)
    assert pad2.recovery(-0.015) == pytest.approx(-0.02)
    assert pad0.recovery(-0.005) == pytest.approx(-0.006)
    assert pad2.escape_floor(-0.01, -0.005) == -0.005       # the floor only rises while escaping
    assert pad2.escape_floor(-0.025, -0.0207) == -0.025     # below its limit: starts over at c0
    assert pad2.escape(pad2.escape_floor(-0.025, -0.0207)) == pytest.approx(-0.026)
    wall = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    wall.data[57, :] = cv.LETHAL_OBSTACLE                 # cells y in [0.35, 0.40)
    pose = (0.0, 0.025, 0.0)                              # left side at 0.335: 1.5 cm from the wall
    step, end = _back_up(BackUpRecovery(padded), wall, pose)
    assert step.done and step.ok and re.fullmatch(r"backed up 0\.(29|30) m", step.reason), step.reason
    # Behind the robot the wall comes 2 cm nearer: it stops before its body would touch.
    wall.data[56, :38] = cv.LETHAL_OBSTACLE              # x < -0.6 m: cells y in [0.30, 0.35)
    wall.data[57, :38] = cv.FREE_SPACE
    step, end = _back_up(BackUpRecovery(padded), wall, (0.0, -0.015, 0.0))
    assert step.done and step.ok and "backing up further would hit" in step.reason
    assert -0.3 < end[0] < -0.05 and not footprint_hits_costmap(wall, footprint, end)
    # Turning on the spot swings the corners into the wall: stopped, but it may try.
    rot = RotateRecovery(padded)
    rot.start(pose)
    assert not rot.step(pose, (0.0, 0.0, 0.0), wall).ok


def test_back_up_recovery_only_retraces_the_way_the_robot_came(footprint):
    """The laser does not see behind the robot: back_up drives only over ground the robot's
    centre has been on (within trail_tolerance of its trail), never into the unknown."""
    free = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    # Never moved (spawned here): no ground behind it it knows.
    step, pose = _back_up(BackUpRecovery(footprint), free, trail=[(0.0, 0.0)])
    assert step.done and not step.ok and "has not driven over" in step.reason and pose == (0.0, 0.0, 0.0)
    # Came 0.15 m straight: backs up 0.15 m (of 0.3), and says why it stopped there.
    step, pose = _back_up(BackUpRecovery(footprint), free, trail=_trail_behind((0.0, 0.0, 0.0), 0.15))
    assert step.done and step.ok and "as far as the robot has come" in step.reason
    assert -0.16 < pose[0] < -0.13
    # Came along a line at 45 degrees to its heading (it turned on the spot since): it
    # leaves the trail by 0.1 m after 0.14 m straight back.
    step, pose = _back_up(BackUpRecovery(footprint), free, trail=_trail_behind((0.0, 0.0, math.pi / 4), 1.0))
    assert step.done and step.ok and -0.16 < pose[0] < -0.12
    assert retrace_distance((0.0, 0.0, 0.0), _trail_behind((0.0, 0.0, 0.0), 1.0), 0.3, 0.1) == pytest.approx(0.3)
    assert retrace_distance((0.0, 0.0, 0.0), [], 0.3, 0.1) == 0.0


def footprint_hits_costmap(costmap, footprint, pose):
    poly = footprint.oriented(*pose)
    mx, my, inside = costmap.world_to_map_array(poly)
    return (~inside).any() or (costmap.data[my, mx] == cv.LETHAL_OBSTACLE).any()


def test_recovery_behaviors_list(footprint):
    spec = [{"name": "conservative_reset", "type": CLEAR_TYPE}, {"name": "back_up", "type": BACKUP_TYPE},
            {"name": "rotate_recovery", "type": ROTATE_TYPE},
            {"name": "aggressive_reset", "type": CLEAR_TYPE}]
    ctx = PluginContext(footprint=footprint, controller_frequency=10.0, local_limits={"max_rotational_vel": 0.8})
    seq = recovery_sequence(spec, {"aggressive_reset": {"reset_distance": 1.84}, "back_up": {"backup_dist": 0.2}},
                            ctx)
    assert [n for n, _ in seq] == ["conservative_reset", "back_up", "rotate_recovery", "aggressive_reset"]
    (_, cons), (_, back), (_, rot), (_, aggr) = seq
    assert isinstance(cons, ClearCostmapRecovery) and cons.reset_distance == 3.0      # clear_costmap_recovery's default
    assert aggr.reset_distance == 1.84 and cons.layer_names == ("obstacles",)      # the real default
    assert back.backup_dist == 0.2 and back.frequency == 10.0                      # its namespace wins
    assert rot.max_rotational_vel == 0.8
    for bad, match in [([], "non-empty list"), ("back_up", "non-empty list"),
                       ([{"name": "x"}], r"recovery_behaviors\[0\]: expected"),
                       ([{"name": "a", "type": CLEAR_TYPE}, {"name": "a", "type": ROTATE_TYPE}], "used twice"),
                       ([{"name": "a", "type": "moveback_recovery/MoveBackRecovery"}], "unknown type"),
                       ([{"name": "b", "type": BACKUP_TYPE}], r"\(b\): backup_speed")]:
        with pytest.raises(ValueError, match=match):
            recovery_sequence(bad, {"b": {"backup_speed": 0}}, PluginContext(footprint=footprint))
    # A name the behaviour does not read is noted and left unread (it used to refuse the whole
    # list for move_base's defaults), as the real recovery behaviours leave it.
    (_, b), (_, c), (_, r) = recovery_sequence(
        [{"name": "b", "type": BACKUP_TYPE}, {"name": "c", "type": CLEAR_TYPE}, {"name": "r", "type": ROTATE_TYPE}],
        {"b": {"speed": 0.1, "backup_dist": 0.25}, "c": {"reset_distanse": 1.0}, "r": {"frequency": 5.0, "acc_lim_x": 1}},
        PluginContext(footprint=footprint))
    assert b.backup_dist == 0.25 and c.reset_distance == 3.0 and r.frequency == 5.0
    assert b.notes == ["~b: 'speed' is not a parameter this node reads; ignored"], b.notes
    assert "'reset_distanse'" in c.notes[0] and "reset_distance" in c.notes[0]
    assert len(r.notes) == 1 and "'acc_lim_x'" in r.notes[0]


def test_config_files_load():
    p = load_move_base_params(CONFIG)
    assert p.dwa.max_vel_x == 1.0 and p.dwa.vth_samples == 40
    assert p.navfn.allow_unknown is False
    g = build_costmap(p.global_costmap)
    loc = build_costmap(p.local_costmap)
    assert [l.name for l in g.layers] == ["static_layer", "obstacle_layer", "inflation_layer"]
    assert loc.rolling_window and loc.master.size_x == 140
    # The global footprint is padded so that the planner keeps DWA's room (see
    # test_planner_dwa_consistency.py); the local one is the robot's plus 1 cm of margin.
    assert loc.footprint.inscribed_radius == pytest.approx(0.32)
    assert g.footprint.inscribed_radius == pytest.approx(0.355)


@pytest.mark.parametrize("fname,ns,key,value,match", [
    ("dwa_local_planner_params.yaml", "DWAPlannerROS", "vx_samples", "many", "must be int"),
    ("navfn_global_planner_params.yaml", "NavfnROS", "allow_unknown", "yes", "must be bool"),
    ("navfn_global_planner_params.yaml", "NavfnROS", "default_tolerance", -1.0, ">= 0"),
])
def test_bad_params_are_named(tmp_path, fname, ns, key, value, match):
    for f in (f for f in os.listdir(CONFIG) if f.endswith(".yaml")):  # the course's files, not navigation_stage/
        shutil.copy(os.path.join(CONFIG, f), tmp_path / f)
    doc = yaml.safe_load(open(tmp_path / fname))
    doc[ns][key] = value
    yaml.safe_dump(doc, open(tmp_path / fname, "w"))
    with pytest.raises(ParamError, match=match):
        getattr(load_move_base_params(str(tmp_path)), "dwa" if ns == "DWAPlannerROS" else "navfn")


def test_old_dwa_names_are_not_read(tmp_path):
    """As the real DWAPlannerROS: a renamed parameter under its old name is warned about and
    not read (the default stands), in the course's files too."""
    for f in (f for f in os.listdir(CONFIG) if f.endswith(".yaml")):  # the course's files, not navigation_stage/
        shutil.copy(os.path.join(CONFIG, f), tmp_path / f)
    doc = yaml.safe_load(open(tmp_path / "dwa_local_planner_params.yaml"))
    doc["DWAPlannerROS"]["max_rot_vel"] = 2.0
    del doc["DWAPlannerROS"]["max_vel_theta"]
    yaml.safe_dump(doc, open(tmp_path / "dwa_local_planner_params.yaml", "w"))
    assert load_move_base_params(str(tmp_path)).dwa.max_vel_theta == 1.0


def test_turn_around_in_the_recovery_list_and_its_bad_parameters(footprint):
    spec = [{"name": "turn_around", "type": TURN_AROUND_TYPE}, {"name": "back_up", "type": BACKUP_TYPE}]
    ctx = PluginContext(footprint=footprint, controller_frequency=10.0,
                        local_limits={"min_in_place_rotational_vel": 0.4, "max_rotational_vel": 0.8, "acc_lim_x": 2.0})
    seq = recovery_sequence(spec, {"turn_around": {"reach": 0.8}}, ctx)
    (_, turn), _ = seq
    assert isinstance(turn, TurnAroundRecovery) and turn.search["reach"] == 0.8
    assert turn.frequency == 10.0 and turn.rot_vel == 0.4           # move_base's rate, DWA's min_vel_theta
    for own, match in [({"speed": 0}, "speed"), ({"keep": -0.01}, "keep"), ({"replans": 1.5}, "replans"),
                       ({"reach": float("nan")}, "reach")]:
        with pytest.raises(ValueError, match=r"\(t\): " + match):
            recovery_sequence([{"name": "t", "type": TURN_AROUND_TYPE}], {"t": own}, PluginContext(footprint=footprint))


def _pocket(footprint, back):
    """A robot at (0, 0) facing +x, nose first in a dead end 0.76 m wide, 0.5 m deep: walls
    along both sides of its front half and 0.06 m ahead of its nose; a wall across
    behind it at back [m]."""
    m = Costmap2D(120, 120, 0.05, -3.0, -3.0)
    for x0, y0, x1, y1 in [(0.0, 0.38, 0.5, 0.6), (0.0, -0.6, 0.5, -0.38), (0.42, -0.6, 0.6, 0.6),
                           (-back - 0.2, -0.6, -back, 0.6)]:
        a, b = m.world_to_map_no_bounds(x0, y0), m.world_to_map_no_bounds(x1, y1)
        m.data[a[1]:b[1] + 1, a[0]:b[0] + 1] = cv.LETHAL_OBSTACLE
    return m


def test_turn_around_recovery_backs_out_of_a_dead_end_or_says_there_is_no_way(footprint):
    padded = Footprint.from_params(SUMMIT_FOOTPRINT, padding=0.02)
    free = Costmap2D(100, 100, 0.05, -2.5, -2.5)
    rec = TurnAroundRecovery(padded)
    rec.start((0.0, 0.0, 0.0))
    step = rec.step((0.0, 0.0, 0.0), (0, 0, 0), free)
    assert step.done and step.ok and "room already" in step.reason and step.cmd == (0.0, 0.0, 0.0)
    # Boxed in all round (a wall 0.1 m behind the tail too): no way out, and no command.
    boxed = _pocket(padded, back=0.42)
    assert plan_manoeuvre(padded, boxed, (0.0, 0.0, 0.0)) is None
    rec.start((0.0, 0.0, 0.0))
    step = rec.step((0.0, 0.0, 0.0), (0, 0, 0), boxed)
    assert step.done and not step.ok and "no way out" in step.reason and step.cmd == (0.0, 0.0, 0.0)
    # Open behind: it backs out (a perfect robot) without touching.
    m = _pocket(padded, back=2.5)
    moves = plan_manoeuvre(padded, m, (0.0, 0.0, 0.0))
    assert moves and all(v <= 0 for v, _ in moves)
    step, pose = run_recovery(rec, (0.0, 0.0, 0.0), m, check=lambda p: not _hits(m, padded, p))
    assert step.ok, step.reason
    assert pose[0] <= -0.25


def _hits(m, footprint, pose):
    """The unpadded footprint's points (a 15 x 15 grid) on a lethal cell."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    u, v = np.meshgrid(np.linspace(-0.36, 0.36, 15), np.linspace(-0.31, 0.31, 15))
    x, y = pose[0] + c * u - s * v, pose[1] + s * u + c * v
    mx, my = np.floor((x + 3.0) / 0.05).astype(int), np.floor((y + 3.0) / 0.05).astype(int)
    return bool((m.data[my, mx] == cv.LETHAL_OBSTACLE).any())


def test_clear_keeps_the_cells_strictly_inside_the_square_as_clear_area(footprint):
    """costmap_2d's CostmapLayer::clearArea keeps (or, inverted, clears) the cells strictly
    between the cells of the square's corners: x > start_x && x < end_x. Ours kept the
    corner cells' rows and columns too, one cell more on each side (review, session 28)."""
    for invert in (False, True):
        lc = _with_obstacles(footprint)
        layer = lc.layer("obstacle_layer")
        layer.grid.data[:] = cv.LETHAL_OBSTACLE
        robot, d = (0.33, -0.21), 1.0
        clear_costmap_layers(lc, robot, d, ("obstacle_layer",), invert=invert)
        m = layer.grid
        sx, sy = m.world_to_map_no_bounds(robot[0] - d / 2, robot[1] - d / 2)
        ex, ey = m.world_to_map_no_bounds(robot[0] + d / 2, robot[1] + d / 2)
        xs, ys = np.meshgrid(np.arange(m.size_x), np.arange(m.size_y))
        inside = (xs > sx) & (xs < ex) & (ys > sy) & (ys < ey)
        kept = (m.data == cv.LETHAL_OBSTACLE)
        np.testing.assert_array_equal(kept, inside if not invert else ~inside)


def test_rotate_recovery_refuses_a_step_that_is_not_positive(footprint):
    for bad in (0.0, -0.1, float("nan")):
        with pytest.raises(ValueError, match="sim_granularity: expected a positive number"):
            RotateRecovery(footprint, sim_granularity=bad)
