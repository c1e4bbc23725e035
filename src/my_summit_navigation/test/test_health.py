"""Unit tests of the navigation health report (my_summit_navigation.health), without ROS."""
import json
import math

import cv2
import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_navigation import health as h
from summit_nav_common.map_io import GridMap


def circle_track(t, period=60.0, r=3.0, centre=(5.0, 5.0)):
    """(x, y, yaw) of a robot driving a circle anticlockwise, one lap per period [s]."""
    th = 2 * math.pi * t / period
    return centre[0] + r * np.cos(th), centre[1] + r * np.sin(th), (th + math.pi / 2 + math.pi) % (2 * math.pi) - math.pi


def test_stats_of_a_known_sample_and_of_nothing():
    s = h.stats([0.0, 0.1, 0.2, 0.3, np.nan, 1.0])
    assert s["samples"] == 5 and s["median"] == pytest.approx(0.2) and s["worst"] == 1.0
    assert_allclose(s["p95"], np.percentile([0, 0.1, 0.2, 0.3, 1.0], 95))
    assert h.stats([]) == {"samples": 0, "median": None, "p95": None, "worst": None}


def test_interpolation_is_linear_and_yaw_takes_the_short_arc():
    t = np.array([0.0, 1.0, 2.0])
    x, y = np.array([0.0, 1.0, 3.0]), np.array([0.0, -1.0, -1.0])
    yaw = np.array([3.0, -3.0, -3.0])   # crosses +-pi between 0 and 1 s
    xi, yi, yawi = h.interpolate_track([0.5, 1.5, 2.0], t, x, y, yaw)
    assert_allclose(xi, [0.5, 2.0, 3.0])
    assert_allclose(yi, [-0.5, -1.0, -1.0])
    assert abs(abs(yawi[0]) - math.pi) < 1e-9   # midway across the seam, not 0


def test_no_truth_outside_the_track_or_across_a_gap():
    t = np.array([0.0, 0.1, 0.2, 5.0, 5.1])
    z = np.zeros(5)
    xi, _, _ = h.interpolate_track([-0.1, 0.15, 2.5, 5.05, 6.0], t, np.arange(5.0), z, z, max_gap=0.5)
    assert np.isnan(xi[0]) and np.isnan(xi[2]) and np.isnan(xi[4])
    assert_allclose(xi[[1, 3]], [1.5, 3.5])


def test_localization_error_against_interpolated_truth():
    """amcl stamps fall between truth samples: a 0.05 m offset is found exactly, not the
    0.3 m/s x 0.05 s of a nearest-sample match."""
    tt = np.arange(0.0, 10.0, 0.1)
    x, y, yaw = circle_track(tt)
    truth = np.c_[tt, x, y, yaw, np.full_like(tt, 0.3)]
    ta = np.arange(0.05, 9.9, 0.5)
    xa, ya, yawa = circle_track(ta)
    amcl = np.c_[ta, xa + 0.05, ya, yawa + 0.01]
    pos, head = h.localization_errors(amcl, truth)
    assert_allclose(pos, 0.05, atol=2e-3)
    assert_allclose(head, 0.01, atol=1e-3)


def test_active_intervals_and_rates_in_whole_windows():
    status = [(0.0, False), (1.0, True), (4.5, False), (6.0, True)]
    iv = h.active_intervals(status, t_end=8.2)
    assert iv == [(1.0, 4.5), (6.0, 8.2)]
    cmd = np.concatenate([np.arange(1.0, 4.5, 0.05), np.arange(6.0, 8.2, 0.1)])   # 20 Hz, then 10 Hz
    rates = h.window_rates(cmd, iv)
    assert_allclose(rates, [20, 20, 20, 10, 10], atol=1)    # 3 + 2 whole windows


def test_cpu_percent_of_wall_and_per_simulated_second():
    pct, per_sim = h.cpu_percent((100.0, 0.0, 5.0), (110.0, 20.0, 8.0))
    assert pct == pytest.approx(30.0) and per_sim == pytest.approx(0.15)
    assert h.cpu_percent((1.0, 1.0, 1.0), (1.0, 1.0, 1.0)) == (None, None)


def test_laps_are_cut_at_each_return_through_the_gate():
    t = np.arange(0.0, 200.0, 0.1)
    x, y, _ = circle_track(t)
    bounds = h.split_laps(np.c_[x, y], (x[0], y[0]))
    assert bounds[0] == 0 and len(bounds) == 4          # three whole laps of 60 s in 200 s
    assert_allclose(np.diff(t[bounds]), 60.0, atol=0.2)


def test_a_cruise_lap_ends_at_its_last_waypoint():
    """The cruise's lap runs from its first waypoint (the gate, at 15 s of a 60 s circle) to
    its last (at 45 s): one lap of one run is complete, from 15 s to 45 s (the robot stops
    short of the gate)."""
    t = np.arange(0.0, 50.0, 0.1)
    x, y, _ = circle_track(t)
    at = lambda s: tuple(np.ravel(v)[0] for v in circle_track(np.array([s]))[:2])  # noqa: E731
    bounds = h.split_laps(np.c_[x, y], at(15.0), finish=at(45.0))
    assert len(bounds) == 2
    assert_allclose(t[bounds], [15.0, 45.0], atol=0.15)


def test_a_robot_starting_off_the_gate_leads_in():
    t = np.arange(0.0, 130.0, 0.1)
    x, y, _ = circle_track(t)
    gate = circle_track(np.array([15.0]))
    bounds = h.split_laps(np.c_[x, y], (gate[0][0], gate[1][0]))
    assert bounds[0] > 0 and len(bounds) == 2


def test_dock_visits_need_a_stop_within_the_radius():
    t = np.arange(0.0, 100.0, 0.1)
    x, y, _ = circle_track(t, period=50.0)
    speed = np.full_like(t, 0.4)
    speed[(t > 20) & (t < 22)] = 0.0                   # stands at t = 20..22 s...
    x[(t > 20) & (t < 22)] = x[t > 20][0]
    y[(t > 20) & (t < 22)] = y[t > 20][0]
    dock = (x[t > 20][0] + 0.1, y[t > 20][0], 0.0)       # ... 0.1 m from the dock
    visits = h.dock_visits(t, np.c_[x, y], speed, dock)
    assert len(visits) == 1 and 18.5 < visits[0][0] <= 20.1 and 21.8 <= visits[0][1] < 23.0
    # the second lap passes the dock without stopping: no visit; a robot that starts
    # standing at the dock has not visited it
    speed[:5] = 0.0
    assert h.dock_visits(t, np.c_[x, y], speed, (x[0], y[0], 0.0)) == []


def test_dock_argument_and_waypoints_file(tmp_path):
    x, y, yaw = h.parse_dock("1.5,-2,90")
    assert (x, y) == (1.5, -2.0) and yaw == pytest.approx(math.pi / 2)
    for bad in ("1,2", "a,b,c", "1,2,nan", ""):
        with pytest.raises(h.HealthError, match="--dock"):
            h.parse_dock(bad)
    f = tmp_path / "wp.yaml"
    f.write_text("dock: {x: -8, y: 1, yaw_deg: 180}\nwaypoints:\n  - [2, 3, 0]\n  - {x: 4, y: 3, yaw_deg: 90}\n")
    dock, first, last = h.read_waypoints(str(f))
    assert_allclose(dock, (-8, 1, math.pi))
    assert first[:2] == (2.0, 3.0) and last[:2] == (4.0, 3.0)
    with pytest.raises(h.HealthError, match="nope.yaml"):
        h.read_waypoints(str(tmp_path / "nope.yaml"))
    f.write_text("dock: [1, 2]\n")
    with pytest.raises(h.HealthError, match="dock"):
        h.read_waypoints(str(f))
    f.write_text("- [1, 2, 3]\n")
    with pytest.raises(h.HealthError, match="mapping"):
        h.read_waypoints(str(f))


def synthetic_recording(loc_offset=0.05, plan_time=0.2, cmd_hz=20.0):
    """Two laps of 60 s with amcl off by loc_offset [m], plans of plan_time [s], cmd_vel
    at cmd_hz while the goal is active, a battery draining 1 % per 10 s, a dock stop."""
    rec = h.Recording()
    t = np.arange(0.0, 130.0, 0.05)
    x, y, yaw = circle_track(t)
    speed = np.full_like(t, 0.31)
    stop = (t > 100) & (t < 110)
    speed[stop] = 0.0
    x[stop], y[stop] = x[t > 100][0], y[t > 100][0]
    rec.truth = list(zip(t, x, y, yaw, speed))
    rec.amcl = [(ti, xi + loc_offset, yi, yawi) for ti, xi, yi, yawi in zip(t[::8], x[::8], y[::8], yaw[::8])]
    rec.plan_times = [(ti, plan_time) for ti in range(0, 130, 5)]
    rec.goal_active = [(0.0, True), (100.0, False), (110.0, True)]
    rec.cmd_vel = list(np.arange(0.0, 130.0, 1.0 / cmd_hz))
    rec.battery = [(ti, 1.0 - ti / 1000.0, False) for ti in range(0, 130)]
    return rec, (x[t > 100][0], y[t > 100][0], 0.0)


def test_report_of_a_healthy_run_passes_and_is_json():
    rec, dock = synthetic_recording()
    nodes = {"/amcl": {"pid": 1, "cpu_percent": 12.0, "cpu_s_per_sim_s": 0.1, "peak_rss_mb": 100.0}}
    r = h.build_report(rec, 0.0, 130.0, nodes, dock, summary={"laps": 2})
    json.dumps(r)
    assert r["localization"]["median_m"] == pytest.approx(0.05, abs=2e-3)
    assert r["planning"]["worst_s"] == 0.2 and r["planning"]["samples"] == 26
    assert r["control_rate"]["mean_hz"] == pytest.approx(20.0, abs=0.5)
    assert r["laps"]["completed"] == 2 and r["laps"]["times_s"][0] == pytest.approx(60.0, abs=0.5)
    assert len(r["dock"]["visits"]) == 1 and r["dock"]["visits"][0]["battery_in_percent"] == pytest.approx(90.0, abs=0.2)
    assert r["battery"]["start_percent"] == 100.0 and r["battery"]["end_percent"] == pytest.approx(87.1)
    assert r["passed"] and r["auto_navigator_summary"] == {"laps": 2}
    assert {c["result"] for c in r["checks"]} <= {h.PASS, h.INFO}


def test_each_threshold_fails_on_its_own():
    rec, dock = synthetic_recording(loc_offset=0.15, plan_time=1.5, cmd_hz=5.0)
    nodes = {"/move_base": {"pid": 2, "cpu_percent": 85.0, "cpu_s_per_sim_s": 0.9, "peak_rss_mb": 1500.0}}
    r = h.build_report(rec, 0.0, 130.0, nodes, dock)
    failed = {c["metric"] for c in r["checks"] if c["result"] == h.FAIL}
    assert failed == {"localization error median [m]", "planning time worst [s]", "control rate mean [Hz]",
                      "CPU /move_base [% core]", "peak memory /move_base [MB]"}
    assert not r["passed"]


def planner_status(last, longest, plans, failed=0):
    """The values of move_base's "Global planner" status (planner_check's keys)."""
    return {"last plan time [s]": last, "max plan time [s]": longest, "plans": str(plans),
            "failed attempts": str(failed)}


def test_plan_sampler_takes_one_sample_per_attempt_and_the_worst_from_the_max():
    """The adapter used to take "last plan time [s]" once per status, de-duplicated by its
    text: move_base's "0" before the first plan was a 0 s plan, two plans between two
    statuses left one, and two plans of equal text counted once; a 1.3 s plan followed by
    a 0.2 s one before the next status never reached the worst."""
    s, name = h.PlanSampler(), "move_base: Global planner"
    assert s.observe(name, planner_status("n/a", "n/a", 0)) == (None, None)   # before the first plan
    assert s.observe(name, planner_status("n/a", "n/a", 0)) == (None, None)
    assert s.observe(name, planner_status("0.2", "0.2", 1)) == (0.2, 0.2)
    assert s.observe(name, planner_status("0.2", "0.2", 1)) == (None, None)  # the same plan repeated
    assert s.observe(name, planner_status("0.2", "0.2", 2)) == (0.2, None)   # a new plan, same time
    assert s.observe(name, planner_status("0.2", "1.3", 4)) == (0.2, 1.3)    # 1.3 s then 0.2 s between
    assert s.observe(name, planner_status("0.9", "1.3", 4, failed=1)) == (0.9, None)   # a failed attempt


def test_plan_sampler_baseline_restart_and_bad_values():
    s = h.PlanSampler()
    # joined mid-run: the attempts already made may predate the report
    assert s.observe("a", planner_status("0.5", "2.0", 7)) == (None, None)
    assert s.observe("a", planner_status("0.3", "2.0", 8)) == (0.3, None)
    assert s.observe("a", planner_status("0.4", "2.0", 1)) == (0.4, 2.0)     # restarted: all new
    assert s.observe("b", planner_status("0.1", "0.1", 1)) == (None, None)   # one baseline per status
    assert s.observe("c", {"last plan time [s]": "0.1"}) == (None, None)     # no count: nothing


def test_report_takes_the_worst_plan_from_the_max():
    rec, dock = synthetic_recording(plan_time=0.2)
    rec.plan_max = [(3.0, 0.2), (40.0, 1.3)]
    r = h.build_report(rec, 0.0, 130.0, {}, dock)
    assert r["planning"]["worst_s"] == 1.3 and r["planning"]["median_s"] == 0.2
    assert {c["metric"] for c in r["checks"] if c["result"] == h.FAIL} == {"planning time worst [s]"}


def test_missing_data_is_reported_as_such_not_as_a_pass():
    r = h.build_report(h.Recording(), 0.0, 10.0)
    rows = {m: res for m, _, _, res in h.check_rows(r)}
    assert rows["planning time worst [s]"] == h.NO_DATA
    assert rows["localization error median [m]"] == h.NO_DATA
    assert rows["control rate mean [Hz]"] == h.NO_DATA
    table = h.format_table(h.check_rows(r))
    assert table.splitlines()[0].split() == ["metric", "value", "threshold", "result"]


def test_nice_ticks_are_round_and_cover_the_range():
    assert h.nice_ticks(0, 100, 4) == [0, 25, 50, 75, 100]
    ticks = h.nice_ticks(3.2, 147.0, 8)
    assert ticks[0] >= 3.2 and ticks[-1] <= 147.0 and len(set(np.round(np.diff(ticks), 9))) == 1
    assert h.round_down_125(7.3) == 5 and h.round_down_125(0.25) == 0.2


def test_pictures_are_drawn_and_encoded():
    rec, dock = synthetic_recording()
    truth = np.asarray(rec.truth)
    grid = GridMap(np.zeros((200, 200), np.int8), 0.05, (0.0, 0.0, 0.0))
    grid.data[:, :5] = 100
    bounds = h.split_laps(truth[:, 1:3], truth[0, 1:3])
    img = h.draw_laps(grid, truth[:, 1:3], bounds, dock, [dock[:2]], "test")
    assert img.ndim == 3 and max(img.shape[:2]) >= h.PICTURE_SIDE
    assert np.any(np.all(img == h.LAP_COLOURS[0], axis=2)) and np.any(np.all(img == h.LAP_COLOURS[1], axis=2))
    png = h.encode_png(img)
    assert cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR).shape == img.shape
    # the wall (map x < 0.25 m) is drawn black left of the circle
    blank = h.draw_laps(None, truth[:, 1:3], bounds, None, (), "no map")
    assert blank.shape[2] == 3
    ts = h.draw_time_series([{"title": "battery", "ylabel": "%", "ylim": (0, 100),
                              "series": [(truth[:, 0], 100 * np.ones(len(truth)), (0, 0, 200))]},
                             {"title": "speed", "ylabel": "m/s", "series": [], "note": "no data"}])
    assert ts.shape[0] == 2 * 230 and np.any(np.all(ts == (0, 0, 200), axis=2))


def test_truth_is_taken_into_the_map_frame():
    truth = [(0.0, 3.0, 8.0, 0.5, 0.2)]
    assert_allclose(h.truth_in_map(truth, (0.0, 0.0, 0.0)), [truth[0]])
    moved = h.truth_in_map(truth, (2.0, 7.0, 0.0))
    assert_allclose(moved, [(0.0, 1.0, 1.0, 0.5, 0.2)])
    turned = h.truth_in_map(truth, (3.0, 8.0, math.pi / 2))
    assert_allclose(turned[0, 1:4], (0.0, 0.0, 0.5 - math.pi / 2), atol=1e-12)
    with pytest.raises(h.HealthError, match="--map-in-world"):
        h.parse_pose_arg("2,7", "--map-in-world")


# --- laps by the cruise's waypoint goals ------------------------------------------------

SUCCEEDED, PREEMPTED, ABORTED = 3, 2, 4
ROUTE = [(5.0, -6.5), (8.0, 1.8), (-4.0, -6.5)]   # first (the gate), middle, last
DOCK_XY = (0.0, -4.0)


class GoalLog:
    """move_base's goals and results as nav_health records them."""

    def __init__(self):
        self.goals, self.results, self.n = [], [], 0

    def drive(self, t_sent, xy, t_done, status=SUCCEEDED):
        self.n += 1
        gid = f"/auto_navigator-{self.n}-{t_sent}"
        self.goals.append((t_sent, gid, xy[0] + 0.01, xy[1] - 0.01))   # within the 0.05 m
        self.results.append((t_done, gid, status))

    def lap(self, t, leg=10.0, skip_last=False):
        """One lap from t [s], legs of leg [s]; the last waypoint aborted three times (the
        cruise gives up on it) when skip_last. Returns the lap's end time."""
        for wp in ROUTE[:-1]:
            self.drive(t, wp, t + leg)
            t += leg
        for _ in range(3 if skip_last else 1):
            self.drive(t, ROUTE[-1], t + leg, ABORTED if skip_last else SUCCEEDED)
            t += leg
        return t


def test_waypoint_laps_end_at_the_last_waypoints_success_and_ignore_a_dock_detour():
    """Lap 2 is cut by a dock visit (its middle goal preempted, the dock goal, then the
    same waypoint again): still one lap; the dock goal and its result count for nothing."""
    g = GoalLog()
    t = g.lap(0.0)                              # lap 1: 0..30 s
    g.drive(t, ROUTE[0], t + 10)                # lap 2 ...
    g.drive(t + 10, ROUTE[1], t + 12, PREEMPTED)   # battery low: canceled
    g.drive(t + 12, DOCK_XY, t + 20)            # the dock (through the gate and back)
    g.drive(t + 80, ROUTE[1], t + 90)           # charged: the same waypoint again
    g.drive(t + 90, ROUTE[-1], t + 100)         # ... lap 2 ends at 130 s
    t = g.lap(t + 100)                          # lap 3: 130..160 s
    g.drive(t, ROUTE[0], t + 10)                # an unfinished lap 4
    assert h.waypoint_laps(g.goals, g.results, ROUTE) == [0.0, 30.0, 130.0, 160.0]


def test_a_skipped_last_waypoint_ends_its_lap_when_the_next_lap_begins():
    """Documented rule: the lap whose last waypoint the cruise gave up on ends when the
    first waypoint's goal of the next lap is sent; the failed retries end nothing; a run
    that ends after such a lap leaves it unfinished."""
    g = GoalLog()
    t = g.lap(0.0, skip_last=True)              # 0..20 s, then 3 failed tries until 50 s
    assert t == 50.0
    t = g.lap(t)                                # lap 2: 50..80 s
    t = g.lap(t, skip_last=True)                # lap 3: 80.., its last skipped, run ends
    assert h.waypoint_laps(g.goals, g.results, ROUTE) == [0.0, 50.0, 80.0]


def test_waypoint_laps_joined_mid_lap_and_a_route_ending_where_it_starts():
    g = GoalLog()
    g.drive(0.0, ROUTE[1], 10.0)                # the report began mid-lap
    g.drive(10.0, ROUTE[2], 20.0)               # the partial lap leads in: laps from 20 s
    t = g.lap(20.0)
    assert h.waypoint_laps(g.goals, g.results, ROUTE) == [20.0, 50.0]
    assert h.waypoint_laps([], [], ROUTE) == [] and h.waypoint_laps(g.goals, g.results, []) == []
    # a loop whose last waypoint is its first: A B A | A B A
    loop = [(0.0, 0.0), (5.0, 0.0), (0.0, 0.0)]
    g = GoalLog()
    for t in (0.0, 30.0):
        for k, wp in enumerate(loop):
            g.drive(t + 10 * k, wp, t + 10 * (k + 1))
    assert h.waypoint_laps(g.goals, g.results, loop) == [0.0, 30.0, 60.0]
    # a result stamped with its goal's own time is still matched to it
    g = GoalLog()
    g.drive(0.0, ROUTE[0], 5.0)
    g.drive(5.0, ROUTE[1], 9.0)
    g.drive(9.0, ROUTE[2], 9.0)
    assert h.waypoint_laps(g.goals, g.results, ROUTE) == [0.0, 9.0]


def test_report_counts_laps_by_waypoint_goals_not_gate_passes():
    """A robot going round a 60 s circle whose gate it passes twice more on a dock
    detour (at 70 s and 80 s, straight through it): the gate rule counts the detour's
    passes, the goals do not; without goals the gate rule stays, and says so."""
    t = np.arange(0.0, 200.0, 0.1)
    x, y, yaw = circle_track(t)
    gate = (x[0], y[0])
    far = (gate[0] - 6.0, gate[1])                        # a detour through the gate
    detour = (t > 65) & (t < 85)
    frac = np.abs((t[detour] - 75.0) / 10.0)               # gate at 65, far at 75, gate at 85
    x[detour] = gate[0] + (far[0] - gate[0]) * (1 - frac)
    y[detour] = gate[1]
    rec = h.Recording()
    rec.truth = list(zip(t, x, y, yaw, np.full_like(t, 0.3)))
    at = lambda s: tuple(np.ravel(v)[0] for v in circle_track(np.array([s]))[:2])  # noqa: E731
    route = [at(0.0), at(20.0), at(40.0)]
    g = GoalLog()
    for lap_t0, wps in ((0.0, [(0, 20), (1, 20), (2, 20)]), (60.0, [(0, 35), (1, 20), (2, 20)]),
                        (135.0, [(0, 20), (1, 20), (2, 20)])):
        tt = lap_t0
        for i, leg in wps:
            g.goals.append((tt, f"g{len(g.goals)}", *route[i]))
            g.results.append((tt + leg, f"g{len(g.results)}", SUCCEEDED))
            tt += leg
    rec.goals, rec.results = g.goals, g.results
    by_goals = h.build_report(rec, 0.0, 200.0, waypoints=route, gate=gate)
    laps = by_goals["laps"]
    assert laps["rule"] == h.RULE_WAYPOINTS and laps["completed"] == 3 and laps["waypoint_goals"] == 9
    assert laps["times_s"] == [60.0, 75.0, 60.0] and laps["boundaries_s"][0] == 0.0
    rows = {m: v for m, v, _, _ in h.check_rows(by_goals)}
    assert rows["laps completed (by waypoint goals)"] == "3" and rows["lap time mean [s]"] == "65.0"
    rule, times, idx = h.lap_boundaries(np.asarray(rec.truth), rec.goals, rec.results, route)
    assert rule == h.RULE_WAYPOINTS and times == [0.0, 60.0, 135.0, 195.0]
    assert_allclose(t[idx], times, atol=0.1 + 1e-9)   # the first truth sample at or after each
    rec.goals, rec.results = [], []                       # teleoperated: no goals
    by_gate = h.build_report(rec, 0.0, 200.0, waypoints=route, gate=gate)
    assert by_gate["laps"]["rule"] == h.RULE_GATE and by_gate["laps"]["completed"] > 3
    assert "laps completed (by gate passes)" in {m for m, _, _, _ in h.check_rows(by_gate)}


def test_anonymous_node_names():
    assert h.is_anonymous("/bench_race_track_31721_1795847153881")
    assert h.is_anonymous("/rostopic_4242_1700000000000") and h.is_anonymous("/nav_health_12_34")
    for name in ("/amcl", "/move_base", "/summit_xl_sim", "/robot_1/amcl", "/node_2"):
        assert not h.is_anonymous(name)


def test_pictures_are_two_pngs_of_the_report():
    """health.pictures: what nav_health writes as laps.png and battery_speed.png."""
    rec, dock = synthetic_recording()
    r = h.build_report(rec, 0.0, 130.0, {}, dock)
    laps_png, battery_png = h.pictures(r, rec, None, dock, 0.0, (None, None, None))
    assert laps_png[:8] == b"\x89PNG\r\n\x1a\n" and battery_png[:8] == b"\x89PNG\r\n\x1a\n"
