"""scripts/bench_planning_core.py's planner combinations: each built by its type string
through the move_base plugin registry with the intended parameters, the pairs the same for
every combination (the JSON keys the benchmark page reads: tests/test_bench_report.py)."""
import json
import math

import numpy as np
import pytest

from my_summit_path_planning.dwa import DWAPlanner
from my_summit_path_planning.global_planner import GlobalPlanner
from my_summit_path_planning.navfn import NavFn
from my_summit_path_planning.plugins import MoveBasePlugins
from my_summit_path_planning.trajectory_planner import TrajectoryPlanner

import bench_planning_core as bench  # the script under test (tests/pytest.ini's pythonpath)


@pytest.fixture(scope="module")
def params():
    return bench.load_move_base_params(bench.CONFIG)


def _plugins(p):
    footprint = bench.build_costmap(p.local_costmap, "local_costmap").footprint
    return MoveBasePlugins(p, footprint=footprint)


@pytest.mark.parametrize("global_kind, cls, dijkstra", [("navfn", NavFn, None), ("astar", GlobalPlanner, False),
                                                        ("dijkstra", GlobalPlanner, True)])
def test_global_planner_of_each_kind_is_built_by_type_with_the_course_settings(params, global_kind, cls, dijkstra):
    plugins = _plugins(bench.combination_params(params, global_kind, "dwa"))
    g = plugins.global_planner
    assert type(g) is cls and plugins.global_type == bench.GLOBAL_KINDS[global_kind][0]
    course = params.namespace("NavfnROS")
    assert g.config.allow_unknown is course["allow_unknown"] is False
    assert g.config.default_tolerance == course["default_tolerance"] == 0.2
    if dijkstra is not None:
        assert g.config.use_dijkstra is dijkstra


@pytest.mark.parametrize("local_kind, cls, dwa_flag", [("dwa", DWAPlanner, None),
                                                       ("trajectory", TrajectoryPlanner, False),
                                                       ("trajectory-dwa", TrajectoryPlanner, True)])
def test_local_planner_of_each_kind_is_built_by_type_and_max_vel_x_reaches_it(params, local_kind, cls, dwa_flag):
    base = _plugins(bench.combination_params(params, "navfn", local_kind)).make_local_planner()
    fast = _plugins(bench.combination_params(params, "navfn", local_kind, max_vel_x=1.5)).make_local_planner()
    assert type(base) is cls and type(fast) is cls
    assert fast.config.max_vel_x == 1.5
    if cls is DWAPlanner:
        assert base.config.max_vel_x == params.dwa.max_vel_x == 1.0 and fast.config.max_vel_trans == 1.5
    else:
        assert base.config.max_vel_x == params.namespace("TrajectoryPlannerROS")["max_vel_x"] == 0.65
        assert base.config.max_vel_theta == 3.0 and base.config.sim_time == 1.0   # the config's, not defaults
        assert base.config.dwa is dwa_flag
    assert params.dwa.max_vel_x == 1.0  # the loaded parameters are left as they were


def test_pairs_are_seeded_connected_and_apart(params):
    a = bench.draw_pairs(params, bench.BUILTIN, 3, seed=0)
    b = bench.draw_pairs(params, bench.BUILTIN, 3, seed=0)
    assert a == b and len(a) == 3
    assert a != bench.draw_pairs(params, bench.BUILTIN, 3, seed=1)
    for pair in a:
        (sx, sy, _), (gx, gy, _) = pair["start"], pair["goal"]
        assert math.hypot(gx - sx, gy - sy) >= bench.MIN_PAIR_DIST
        assert math.hypot(gx - sx, gy - sy) <= pair["geodesic_m"] < math.inf


# -- the closed loop: move_base's core over the simulator ------------------------------------
RES = 0.05   # [m] cells of the hand-built world


def _world(closed_room=False):
    """A 7 m x 4 m hall with walls round it; closed_room: a 2 m x 2 m room walled on every
    side (x 4.5..6.5, y 1..3), its inside free on the map but out of reach."""
    from summit_nav_common.map_io import FREE, OCCUPIED, GridMap
    from summit_xl_sim.world import World
    data = np.full((int(4.0 / RES), int(7.0 / RES)), FREE, np.int8)
    data[:2, :] = data[-2:, :] = OCCUPIED
    data[:, :2] = data[:, -2:] = OCCUPIED
    if closed_room:
        x0, x1, y0, y1 = (int(v / RES) for v in (4.5, 6.5, 1.0, 3.0))
        data[y0:y1, x0:x0 + 2] = data[y0:y1, x1 - 2:x1] = OCCUPIED
        data[y0:y0 + 2, x0:x1] = data[y1 - 2:y1, x0:x1] = OCCUPIED
    return World(GridMap(data, RES, (0.0, 0.0, 0.0)))


def _pair(start, goal):
    return {"start": start, "goal": goal, "geodesic_m": math.hypot(goal[0] - start[0], goal[1] - start[1]),
            "sim_seed": 0}


def test_closed_loop_drives_move_base_core_to_a_goal(params):
    """A 3 m goal in an empty hall: the core plans (at planner_frequency while driving), the
    local planner drives, the goal ends succeeded within tolerance, no recovery, no contact."""
    p = bench.combination_params(params, "navfn", "dwa")
    run = bench.drive_goal(p, _world(), _pair((1.0, 2.0, 0.0), (4.0, 2.2, 0.5)))
    assert run["reached"] and run["failure"] == "", run
    assert run["collisions"] == 0 and run["recoveries"] == 0 and run["recovery_behaviors"] == []
    assert run["xy_error_m"] <= 0.2 + 0.05    # the config's xy_goal_tolerance
    # 3 m at max_vel_x 1 m/s, with the start and the final turn: a few seconds
    assert 3.0 < run["time_s"] < 6.0 and run["ratio"] < 2.0
    # the planner thread's period: one plan at the goal's start, then one per 1 / planner_frequency
    assert run["plans"] == math.floor(run["time_s"] * p.move_base.planner_frequency + 1e-9) + 1
    assert set(run["mode_s"]) <= {"dwa", "stop", "rotate", "goal", "escape", "PLANNING"}
    assert run["dwa_median_ms"] > 0 and run["t_moving_s"] is not None


def test_closed_loop_unreachable_goal_ends_with_move_base_cores_abort_after_the_recoveries(params):
    """A goal inside a walled room: no plan, so after planner_patience the core runs the
    config's recovery behaviours (move_base's default sequence, the real behaviours, each
    followed by planning again) and aborts with move_base's text; the robot only turns."""
    p = bench.combination_params(params, "navfn", "dwa")
    run = bench.drive_goal(p, _world(closed_room=True), _pair((1.5, 2.0, 0.0), (5.5, 2.0, 0.0)), limit=120.0)
    assert not run["reached"]
    assert run["failure"].startswith("aborted: Failed to find a valid plan. Even after executing recovery "
                                     "behaviors."), run["failure"]
    assert run["recovery_behaviors"] == ["conservative_reset", "rotate_recovery", "aggressive_reset",
                                         "rotate_recovery"]
    # five planning phases of planner_patience (the first and one after each behaviour), two turns
    patience = p.move_base.planner_patience
    assert 5 * patience < run["time_s"] < 5 * (patience + 1.0) + 2 * 10.0
    assert run["plan_m"] is None and run["collisions"] == 0
    # while PLANNING the planner is woken every control cycle, not held to planner_frequency
    planning_cycles = run["mode_s"]["PLANNING"] * p.move_base.controller_frequency
    assert run["plans"] >= 0.9 * planning_cycles
    assert math.hypot(run["start"][0] - 1.5, run["start"][1] - 2.0) < 1e-9 and run["xy_error_m"] > 3.9
    assert set(run["mode_s"]) == {"PLANNING", "CLEARING"}


def test_closed_loop_goal_in_a_wall_is_refused_as_the_node_refuses_it(params):
    """A goal on a wall of the map ends at once with the node's invalid-goal text
    (move_base_core.accept_goal), nothing driven."""
    p = bench.combination_params(params, "navfn", "dwa")
    run = bench.drive_goal(p, _world(), _pair((1.0, 2.0, 0.0), (3.0, 0.02, 0.0)))
    assert run["failure"].startswith("aborted: Aborting on goal because it was sent with an invalid goal: goal "
                                     "(3.00, 0.02) is in an obstacle"), run["failure"]
    assert run["time_s"] == 0.0 and run["plans"] == 0 and not run["reached"]


def _without_timings(runs):
    return [{k: v for k, v in r.items() if not k.endswith("_ms")} for r in runs]


def test_pairs_in_parallel_give_the_same_runs_and_each_combination_is_kept_as_it_is_done(tmp_path, monkeypatch):
    """--jobs 2 runs the pairs in forked processes: the same runs, in pair order, as one
    process; --parts keeps each finished combination stamped with the commit, and --resume
    takes it instead of running it again (only from the same clean commit)."""
    one, two, parts = tmp_path / "one.json", tmp_path / "two.json", tmp_path / "parts"
    monkeypatch.setattr(bench, "git_commit", lambda ws: "abc1234")
    assert bench.main(["--skip-navfn", "--runs", "2", "--jobs", "1", "--json", str(one)]) == 0
    assert bench.main(["--skip-navfn", "--runs", "2", "--jobs", "2", "--json", str(two),
                       "--parts", str(parts)]) == 0
    a, b = (json.load(open(p))["closed_loop_builtin"] for p in (one, two))
    assert a["runs"] == b["runs"] == 2
    assert _without_timings(a["runs_detail"]) == _without_timings(b["runs_detail"])
    kept = json.load(open(parts / "closed_loop_builtin.json"))
    assert kept["commit"] == "abc1234" and kept["runs_detail"] == b["runs_detail"]

    def no_run(*args, **kwargs):
        raise AssertionError("a kept combination was run again")
    monkeypatch.setattr(bench, "closed_loop", no_run)
    three = tmp_path / "three.json"
    assert bench.main(["--skip-navfn", "--runs", "2", "--json", str(three), "--parts", str(parts), "--resume"]) == 0
    assert json.load(open(three))["closed_loop_builtin"]["runs_detail"] == b["runs_detail"]
    monkeypatch.setattr(bench, "git_commit", lambda ws: "def5678")     # another commit: run again
    with pytest.raises(AssertionError, match="run again"):
        bench.main(["--skip-navfn", "--runs", "2", "--parts", str(parts), "--resume"])
