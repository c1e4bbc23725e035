"""bench_move_base_live.py: a move_base node live on bench_planning_core's goal pairs. The
runner's refusal of bad input, the reached rule and the summary on hand-made records, the
node's command line; one built-in pair driven live by our move_base (integration)."""
import json
import math
import os
import subprocess
import sys

import pytest
import yaml

import bench_move_base_live as live  # the script under test (tests/pytest.ini's pythonpath)

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCRIPTS = os.path.join(WS, "src", "my_summit_path_planning", "scripts")
RUNNER = os.path.join(SCRIPTS, "bench_move_base_live.py")
CONFIG = os.path.join(WS, "src", "my_summit_path_planning", "config")

DWA_RULE = {"xy_goal_tolerance": 0.10, "yaw_goal_tolerance": 0.06, "max_vel_x": 1.0,
            "local_type": "dwa_local_planner/DWAPlannerROS", "global_type": "navfn/NavfnROS"}


@pytest.mark.parametrize("args, expect", [
    (["--world", "mars"], "--world mars: unknown; expected one of builtin, willow"),
    (["--local-planner", "teb"], "--local-planner teb: unknown; expected one of dwa, trajectory, trajectory-dwa"),
    (["--global-planner", "carrot"], "--global-planner carrot: unknown; expected one of navfn, astar, dijkstra"),
    (["--pairs", "0"], "--pairs must be >= 1, got 0"),
    (["--only", "21"], "--only 21: pair numbers run from 1 to --pairs 20"),        # willow: 20 pairs
    (["--world", "builtin", "--only", "0", "3"], "--only 0: pair numbers run from 1 to --pairs 50"),
    (["--speed", "0"], "--speed must be a finite number > 0"),
    (["--node", "/no/such/move_base"], "--node /no/such/move_base: not an executable file"),
    (["--node", CONFIG + "/move_base_params.yaml"], "not an executable file"),       # a file, not executable
    (["--node-setup", "/tmp/peers_ws/devel/setup.bash"], "--node-setup needs --node"),
    (["--node", "/bin/true", "--node-setup", "/no/setup.bash"], "--node-setup /no/setup.bash: no such file"),
])
def test_runner_bad_input_fails_with_the_reason_before_anything_starts(args, expect, tmp_path, capsys):
    out = tmp_path / "out"
    assert live.main(["--out", str(out)] + args) == 2
    err = capsys.readouterr().err
    assert err.startswith("bench_move_base_live: error: ") and expect in err, err
    assert not out.exists()   # nothing started, no log folder


def test_runner_as_a_command_exits_2_on_bad_input():
    proc = subprocess.run([sys.executable, RUNNER, "--node", "/no/such/move_base"], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, timeout=120)
    assert proc.returncode == 2 and "--node /no/such/move_base: not an executable file" in proc.stderr, proc.stderr


def record(**kw):
    rec = {"pair": 1, "goal": [1.0, 2.0, 0.5], "final": [1.0, 2.0, 0.5], "state": live.SUCCEEDED,
           "text": "Goal reached.", "done": True, "time_s": 12.0, "geodesic_m": 6.0, "plan_m": 8.0, "limit_s": 40.0,
           "collisions": 0}
    rec.update(kw)
    return rec


def test_reached_is_succeeded_within_the_local_planners_tolerances_plus_the_margin():
    on_edge = live.judge(record(final=[1.0 + 0.149, 2.0, 0.5 + 0.109]), DWA_RULE)
    assert on_edge["reached"] and on_edge["failure"] == ""
    assert on_edge["xy_error_m"] == pytest.approx(0.149) and on_edge["yaw_error_rad"] == pytest.approx(0.109)
    assert on_edge["geodesic_ratio"] == pytest.approx(12.0 / 6.0) and on_edge["ratio"] == pytest.approx(12.0 / 8.0)
    far = live.judge(record(final=[1.0, 2.0 - 0.151, 0.5]), DWA_RULE)
    assert not far["reached"] and far["failure"] == "goal reported reached out of tolerance"
    # yaw across +-pi: 0.05 rad off the goal's 3.12 is within; 0.12 is not
    assert live.judge(record(goal=[1.0, 2.0, 3.12], final=[1.0, 2.0, -3.113]), DWA_RULE)["reached"]
    assert not live.judge(record(goal=[1.0, 2.0, 3.12], final=[1.0, 2.0, -3.043]), DWA_RULE)["reached"]
    # the trajectory planner's tolerances are other ones
    tpr = dict(DWA_RULE, xy_goal_tolerance=0.1, yaw_goal_tolerance=0.05, max_vel_x=0.65)
    assert not live.judge(record(final=[1.0, 2.0, 0.5 + 0.105]), tpr)["reached"]
    assert live.judge(record(final=[1.0, 2.0, 0.5 + 0.105]), DWA_RULE)["reached"]
    assert live.judge(record(), tpr)["geodesic_ratio"] == pytest.approx(12.0 / (6.0 / 0.65))


def test_not_reached_names_the_actions_end_or_the_time_limit():
    aborted = live.judge(record(state=4, text="Failed to find a valid plan. Even after executing recovery behaviors.",
                                final=[5.0, 5.0, 0.0]), DWA_RULE)
    assert not aborted["reached"]
    assert aborted["failure"] == "aborted: Failed to find a valid plan. Even after executing recovery behaviors."
    late = live.judge(record(state=1, done=False, time_s=40.0, final=[1.0, 2.0, 0.5]), DWA_RULE)
    assert not late["reached"] and late["failure"] == "timeout (40 s)"   # at the goal, but no answer in time
    assert live.judge(record(plan_m=None), DWA_RULE)["ratio"] is None      # no plan was published


def test_time_limit_is_the_offline_closed_loops():
    assert live.time_limit(3.0, 1.0) == 40.0                  # never before 40 s
    assert live.time_limit(20.0, 1.0) == pytest.approx(120.0)  # 6 x geodesic / max_vel_x
    assert live.time_limit(20.0, 0.65) == pytest.approx(6 * 20.0 / 0.65)


def test_summary_has_bench_planning_cores_shape_with_failed_pairs_and_cpu():
    runs = [live.judge(record(pair=1, time_s=12.0, collisions=0), DWA_RULE),
            live.judge(record(pair=2, time_s=18.0, state=4, text="x", final=[9.0, 9.0, 0.0], plan_m=None,
                              collisions=2), DWA_RULE),
            live.judge(record(pair=3, time_s=30.0), DWA_RULE)]
    for r, cpu in zip(runs, (1.0, 2.0, 3.5)):
        r["cpu_s"] = cpu
    s = live.summarize({"world": "w.yaml", "node": "/x/move_base"}, runs)
    assert s["runs"] == 3 and s["reached_share"] == pytest.approx(2 / 3) and s["collisions"] == 2
    assert s["geodesic_ratio_median"] == pytest.approx(18.0 / 6.0)
    assert s["ratio_median"] == pytest.approx((12.0 / 8.0 + 30.0 / 8.0) / 2)   # over the runs with a plan
    assert s["failed_pairs"] == [2] and s["cpu_s"] == pytest.approx(6.5)
    assert s["world"] == "w.yaml" and s["node"] == "/x/move_base" and s["runs_detail"] == runs
    assert s["late_cycles"] is None          # not counted in these records
    for r, late in zip(runs, (0, 4, 1)):
        r["late_cycles"] = late
    assert live.summarize({}, runs)["late_cycles"] == 5
    runs[0]["cpu_s"] = None
    assert live.summarize({}, runs)["cpu_s"] is None
    empty = live.summarize({}, [])
    assert empty["runs"] == 0 and empty["geodesic_ratio_median"] is None and empty["failed_pairs"] == []


def test_goal_rule_reads_the_local_planners_config():
    dwa = yaml.safe_load(open(os.path.join(CONFIG, "dwa_local_planner_params.yaml")))["DWAPlannerROS"]
    tpr = yaml.safe_load(open(os.path.join(CONFIG, "base_local_planner_params.yaml")))["TrajectoryPlannerROS"]
    r = live.goal_rule("navfn", "dwa")
    assert r["local_type"] == "dwa_local_planner/DWAPlannerROS" and r["global_type"] == "navfn/NavfnROS"
    assert (r["xy_goal_tolerance"], r["yaw_goal_tolerance"], r["max_vel_x"]) == (
        dwa["xy_goal_tolerance"], dwa["yaw_goal_tolerance"], dwa["max_vel_x"])
    for kind in ("trajectory", "trajectory-dwa"):
        r = live.goal_rule("astar", kind)
        assert r["local_type"] == "base_local_planner/TrajectoryPlannerROS"
        assert r["global_type"] == "global_planner/GlobalPlanner"
        assert (r["xy_goal_tolerance"], r["yaw_goal_tolerance"], r["max_vel_x"]) == (
            tpr["xy_goal_tolerance"], tpr["yaw_goal_tolerance"], tpr["max_vel_x"])


def test_the_node_runs_directly_as_move_base_with_the_launch_files_remaps():
    ours = live.node_command()
    assert ours[0] == sys.executable and ours[1].endswith(os.path.join("nodes", "move_base"))
    assert ours[2:] == ["__name:=move_base", "cmd_vel:=/summit_xl_control/cmd_vel", "odom:=/odom"]
    assert live.node_command("/ws/devel/lib/move_base/move_base") == [
        "/ws/devel/lib/move_base/move_base", "__name:=move_base", "cmd_vel:=/summit_xl_control/cmd_vel",
        "odom:=/odom"]
    launch = open(os.path.join(WS, "src", "my_summit_path_planning", "launch", "move_base.launch")).read()
    for name, ns in live.CONFIG_FILES:   # the files and namespaces move_base.launch loads, in its order
        assert f'config_dir)/{name}" command="load"' + (f' ns="{ns}"' if ns else "/>") in launch
    assert [n for n, _ in live.CONFIG_FILES] == [
        line.split("config_dir)/")[1].split('"')[0] for line in launch.splitlines() if "config_dir)/" in line
        and "rosparam" in line]


@pytest.mark.integration
def test_our_move_base_drives_a_builtin_pair_live(tmp_path):
    """Built-in pair 1 (3.0 m of geodesic) driven by our move_base over ROS, judged on
    the simulator's ground truth."""
    res_path = tmp_path / "res.json"
    proc = subprocess.run([sys.executable, RUNNER, "--world", "builtin", "--pairs", "1", "--out", str(tmp_path / "o"),
                           "--json", str(res_path)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=180)
    assert proc.returncode == 0, proc.stdout[-4000:]
    res = json.loads(res_path.read_text())
    run = res["runs_detail"][0]
    assert run["pair"] == 1 and run["reached"] and run["collisions"] == 0, run
    assert run["xy_error_m"] <= 0.15 and math.isfinite(run["time_s"]) and run["time_s"] < run["limit_s"]
    assert res["reached_share"] == 1.0 and res["failed_pairs"] == [] and res["cpu_s"] > 0.0
    assert run["driven_m"] >= 0.9 * math.hypot(run["goal"][0] - run["start"][0], run["goal"][1] - run["start"][1])
    # the trace: from the goal to the result every TRACE_DT, ending where the robot was judged
    lines = (tmp_path / "o" / "pair01_trace.csv").read_text().splitlines()
    assert lines[0] == "t,x,y,yaw,cmd_vx,cmd_wz"
    rows = [[float(v) for v in line.split(",")] for line in lines[1:]]
    ts = [r[0] for r in rows]
    assert ts == sorted(ts) and ts[0] < 1.0 and ts[-1] >= run["time_s"] - 1.0 and len(rows) >= run["time_s"] / 0.5
    assert math.hypot(rows[-1][1] - run["final"][0], rows[-1][2] - run["final"][1]) < 0.1
    assert max(r[4] for r in rows) > 0.1   # the command was recorded (it drove forward)


def test_late_cycles_counts_move_bases_warning(tmp_path):
    """A node that cannot keep up with the simulated speed says so; the count goes into the
    record (the real DWAPlannerROS at 3x was late on 4947 cycles of 20 pairs)."""
    log = tmp_path / "move_base.log"
    log.write_text("[ WARN] [1.0, 6.71]: Control loop missed its desired rate of 20.0000Hz... the loop actually "
                   "took 0.0800 seconds\n[ INFO] goal reached\n[ WARN] Control loop missed its desired rate of "
                   "20.0000Hz... the loop actually took 0.1000 seconds\n")
    assert live.late_cycles(str(log)) == 2
    assert live.late_cycles(str(tmp_path / "missing.log")) is None
