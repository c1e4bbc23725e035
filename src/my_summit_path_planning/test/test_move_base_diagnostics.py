"""move_base's diagnostic checks: each level, and the key names the health report reads."""
from my_summit_path_planning.diagnostics import (PlanTimes, controller_check, costmaps_check, planner_check,
                                                 recovery_check)
from summit_nav_common.diagnostic_checks import OK, WARN, RateReading


def test_controller_at_its_frequency_is_ok():
    c = controller_check(RateReading(19.8, 20, 10.0), 20.0, True)
    assert c.level == OK
    assert dict(c.values)["rate [Hz]"] == "19.8" and dict(c.values)["controller_frequency [Hz]"] == "20"


def test_controller_below_90_percent_warns():
    c = controller_check(RateReading(17.9, 18, 10.0), 20.0, True)
    assert c.level == WARN and "below 90%" in c.message


def test_controller_idle_is_ok_with_rate_0():
    c = controller_check(RateReading(None, 0, None), 20.0, False)
    assert (c.level, c.message) == (OK, "idle: no goal") and dict(c.values)["rate [Hz]"] == "0"


def test_controller_stalled_during_a_goal_warns_and_a_first_cycle_does_not():
    assert controller_check(RateReading(None, 0, 3.0), 20.0, True).level == WARN
    assert controller_check(RateReading(None, 1, 3.0), 20.0, True).level == OK


def test_planner_levels():
    c = planner_check(None, 0.0, 0, 0, "")
    # before the first plan: "n/a", which a reader cannot take for a 0 s plan
    assert c.level == OK and dict(c.values)["last plan time [s]"] == "n/a"
    assert dict(c.values)["max plan time [s]"] == "n/a"
    c = planner_check(0.05, 0.4, 3, 0, "")
    assert c.level == OK
    assert [k for k, _ in c.values][:3] == ["last plan time [s]", "max plan time [s]", "plans"]
    assert dict(c.values)["last plan time [s]"] == "0.05" and dict(c.values)["plans"] == "3"
    c = planner_check(1.2, 1.2, 4, 0, "")
    assert c.level == WARN and "1.20 s" in c.message
    c = planner_check(0.05, 0.4, 3, 1, "no path to the goal")
    assert c.level == WARN and "no path to the goal" in c.message


def test_plan_times_track_the_last_attempt():
    t = PlanTimes()
    t.add(0.2, False, "blocked")
    assert t.read() == (0.2, 0.2, 0, 1, "blocked")
    t.add(0.1, True)
    assert t.read() == (0.1, 0.2, 1, 1, "")


def test_costmaps_levels():
    ok = costmaps_check([("global_costmap", RateReading(1.0, 1, 99.5), 1.0),
                         ("local_costmap", RateReading(5.0, 5, 99.9), 5.0)], now=100.0)
    assert ok.level == OK
    assert dict(ok.values) == {"global_costmap rate [Hz]": "1", "global_costmap update_frequency [Hz]": "1",
                               "local_costmap rate [Hz]": "5", "local_costmap update_frequency [Hz]": "5"}
    slow = costmaps_check([("local_costmap", RateReading(3.0, 3, 99.9), 5.0)], now=100.0)
    assert slow.level == WARN and "local_costmap: 3.0 Hz" in slow.message
    silent = costmaps_check([("local_costmap", RateReading(None, 0, 90.0), 5.0)], now=100.0)
    assert silent.level == WARN and "no update for 10.0 s" in silent.message
    never = costmaps_check([("global_costmap", RateReading(None, 0, None), 1.0)], now=100.0)
    assert never.level == WARN and "no update yet" in never.message
    static = costmaps_check([("global_costmap", RateReading(None, 0, 2.0), 0.0)], now=100.0)
    assert static.level == OK   # update_frequency 0: updated once, by design


def test_recovery_levels():
    assert recovery_check(None, 0).level == OK
    c = recovery_check((1, 3, "rotate_recovery"), 2)
    assert c.level == WARN and "2/3 running: rotate_recovery" in c.message
    assert dict(c.values)["recovery"] == "rotate_recovery"
