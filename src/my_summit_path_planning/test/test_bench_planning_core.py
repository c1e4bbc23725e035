"""scripts/bench_planning_core.py's planner combinations: each built by its type string
through the move_base plugin registry with the intended parameters, the pairs the same for
every combination, and the JSON keys the benchmark page (tools/bench_report.py) reads."""
import importlib.util
import math
import os

import pytest

from my_summit_path_planning.dwa import DWAPlanner
from my_summit_path_planning.global_planner import GlobalPlanner
from my_summit_path_planning.navfn import NavFn
from my_summit_path_planning.plugins import MoveBasePlugins
from my_summit_path_planning.trajectory_planner import TrajectoryPlanner

HERE = os.path.dirname(os.path.abspath(__file__))
WS = os.path.abspath(os.path.join(HERE, "..", "..", ".."))


def _load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


bench = _load("bench_planning_core", os.path.join(HERE, "..", "scripts", "bench_planning_core.py"))
bench_report = _load("bench_report", os.path.join(WS, "tools", "bench_report.py"))


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


def test_json_keys_are_the_ones_the_benchmark_page_reads():
    keys = set()
    for world, _ in bench.WORLDS:
        for g in bench.GLOBAL_PLANNERS:
            for loc in bench.LOCAL_PLANNERS:
                key = bench.combination_key(world, g, loc)
                assert key == bench_report.closed_loop_key(world, g, loc)
                keys.add(key)
    assert len(keys) == 2 * 3 * 3
    assert bench.combination_key("builtin", "navfn", "dwa") == "closed_loop_builtin"
    assert bench.combination_key("willow", "navfn", "dwa") == "closed_loop_willow"
    assert bench.combination_key("builtin", "navfn", "trajectory") == "closed_loop_builtin_trajectory"
    assert [w for w, _ in bench.WORLDS] == list(bench_report.CLOSED_WORLDS)
    assert list(bench.GLOBAL_PLANNERS) == list(bench_report.CLOSED_GLOBAL)
    assert list(bench.LOCAL_PLANNERS) == list(bench_report.CLOSED_LOCAL)
