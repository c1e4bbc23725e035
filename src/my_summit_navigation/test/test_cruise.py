"""Unit tests of the cruise's state machine (my_summit_navigation.cruise.Cruise) with a
fake clock: a fake move_base answers the Send commands, time is a number."""
import json
import math

import pytest

from my_summit_navigation import cruise as cr
from my_summit_localization.spots import Spot


def stop(name, x, y=0.0):
    return cr.Stop(name, Spot.from_xy_yaw(x, y, 0.0))


A, B, C = stop("a", 1.0), stop("b", 2.0), stop("c", 3.0)
DOCK = cr.Stop("dock", Spot.from_xy_yaw(-1.0, 0.0, 0.0))


class Run:
    """A cruise and its command stream; sent() is the last Send."""

    def __init__(self, stops=(A, B, C), **kw):
        kw.setdefault("retry_pause", 1.0)
        self.cruise = cr.Cruise(list(stops), **kw)
        self.t = 0.0
        self.cmds = []

    def do(self, cmds):
        self.cmds += cmds
        return cmds

    def start(self):
        return self.do(self.cruise.start(self.t))

    def sent(self):
        return [c for c in self.cmds if isinstance(c, cr.Send)][-1]

    def sends(self):
        return [c.stop.name for c in self.cmds if isinstance(c, cr.Send)]

    def finish(self, state=cr.SUCCEEDED, text="", dt=10.0):
        """The current goal ends after dt [s]."""
        self.t += dt
        return self.do(self.cruise.goal_done(self.sent().goal_id, state, text, self.t))

    def tick(self, dt):
        self.t += dt
        return self.do(self.cruise.tick(self.t))

    def battery(self, pct, dt=0.0, status=cr.POWER_UNKNOWN):
        self.t += dt
        return self.do(self.cruise.battery(pct, self.t, status))

    def feedback(self, x, y=0.0, dt=1.0):
        self.t += dt
        return self.do(self.cruise.feedback(self.sent().goal_id, x, y, self.t))

    def summary(self):
        return [c for c in self.cmds if isinstance(c, cr.Finish)][-1].summary

    def logs(self, level=None):
        return [c.text for c in self.cmds if isinstance(c, cr.Log) and (level is None or c.level == level)]


def test_a_normal_lap_reaches_every_waypoint_in_order_and_times_the_lap():
    r = Run(laps=1)
    r.start()
    for _ in range(3):
        r.finish(dt=10.0)
    assert r.sends() == ["a", "b", "c"]
    s = r.summary()
    assert s["state"] == cr.COMPLETED and s["laps"] == 1 and s["reached"] == 3 and s["skipped"] == []
    assert s["lap_times_s"] == [30.0] and s["time_s"] == 30.0 and s["dock_visits"] == 0 and s["retries"] == 0
    assert any("'b' reached after 10.0 s" in line for line in r.logs())
    assert any("lap 1 done in 30.0 s" in line for line in r.logs())
    json.dumps(s)   # the summary is JSON as it is


def test_laps_are_counted_and_each_has_its_time():
    r = Run(stops=(A, B), laps=3)
    r.start()
    for dt in (5, 5, 10, 10, 20, 20):
        r.finish(dt=dt)
    s = r.summary()
    assert s["laps"] == 3 and s["reached"] == 6 and s["lap_times_s"] == [10.0, 20.0, 40.0]
    assert r.sends() == ["a", "b"] * 3
    assert r.cruise.done and r.cruise.status()[0] == cr.OK


def test_laps_zero_runs_on():
    r = Run(stops=(A,), laps=0)
    r.start()
    for _ in range(50):
        r.finish()
    assert not r.cruise.done and r.cruise.laps_done == 50 and r.cruise.lap == 51


def test_aborted_clears_the_costmaps_retries_then_skips_with_the_reason():
    r = Run(laps=1, max_retries=2)
    r.start()
    r.finish()                                              # a reached
    for attempt in (1, 2):
        out = r.finish(cr.ABORTED, "Failed to find a valid plan")
        assert any(isinstance(c, cr.ClearCostmaps) for c in out)
        assert not any(isinstance(c, cr.Send) for c in out)  # the retry waits RETRY_PAUSE
        assert r.cruise.status()[0] == cr.WARN
        assert not any(isinstance(c, cr.Send) for c in r.tick(0.5))
        assert r.sent().stop.name == "b" and isinstance(r.tick(0.6)[-1], cr.Send)
    r.finish(cr.ABORTED, "Failed to find a valid plan")     # third try: skip, on to c
    assert r.sends() == ["a", "b", "b", "b", "c"]
    r.finish()
    s = r.summary()
    assert s["reached"] == 2 and s["retries"] == 2
    assert s["skipped"] == [{"waypoint": "b", "lap": 1,
                             "reason": "move_base aborted: Failed to find a valid plan (after 3 tries)"}]
    assert any("'b' SKIPPED" in line for line in r.logs(cr.WARN))


def test_a_waypoint_move_base_rejects_is_skipped_with_its_reason():
    r = Run(stops=(A, B), laps=1, max_retries=0)
    r.start()
    r.finish(cr.REJECTED, "The goal is in an obstacle")
    r.finish()
    assert r.summary()["skipped"][0]["reason"].startswith(
        "move_base ended the goal (state 5): The goal is in an obstacle")


def test_a_stall_cancels_recovers_and_retries():
    r = Run(laps=1, movement_timeout=30.0)
    r.start()
    r.feedback(0.0, dt=1.0)                  # 1 m from a
    r.feedback(0.5, dt=10.0)                 # progress
    assert r.feedback(0.55, dt=25.0) == []   # 25 s without 0.1 m: not yet
    out = r.feedback(0.56, dt=6.0)           # 31 s: stuck
    assert isinstance(out[-1], cr.Cancel) and "no progress" in out[0].text
    out = r.finish(cr.PREEMPTED, "", dt=0.2)  # move_base confirms the cancel
    assert isinstance(out[-1], cr.ClearCostmaps) and r.cruise.activity == cr.RECOVERING
    assert r.cruise.status()[0] == cr.WARN
    r.tick(1.5)
    assert r.sends() == ["a", "a"] and r.cruise.activity == cr.RETRYING
    r.finish()
    assert r.cruise.activity == cr.CRUISING
    assert r.cruise.log.retried == 1 and r.cruise.log.reached == 1


def test_a_goal_that_succeeds_while_the_stall_cancel_travels_is_reached_not_retried():
    """move_base reached the goal before the stall's cancel got there: SUCCEEDED counts,
    as it does when the cancel was the battery's."""
    assert cr.decide(cr.SUCCEEDED, "", 1, 2, stuck=True) == (cr.NEXT, "reached")
    r = Run(laps=1, movement_timeout=30.0)
    r.start()
    r.feedback(0.0, dt=1.0)
    assert isinstance(r.feedback(0.01, dt=31.0)[-1], cr.Cancel)    # stuck: cancel
    out = r.finish(cr.SUCCEEDED, "", dt=0.2)                        # but it got there
    assert not any(isinstance(c, cr.ClearCostmaps) for c in out)
    assert r.sends() == ["a", "b"] and r.cruise.activity == cr.CRUISING
    assert r.cruise.log.reached == 1 and r.cruise.log.retried == 0


def test_a_goal_without_any_feedback_stalls_too_and_an_unanswered_cancel_is_not_waited_for_ever():
    r = Run(laps=1, movement_timeout=30.0)
    r.start()
    assert not any(isinstance(c, cr.Cancel) for c in r.tick(29.0))
    assert isinstance(r.tick(2.0)[-1], cr.Cancel)
    r.tick(cr.CANCEL_WAIT + 0.5)            # move_base never answers the cancel
    assert any(isinstance(c, cr.ClearCostmaps) for c in r.cmds)
    r.tick(1.5)
    assert r.sends() == ["a", "a"]


def test_low_battery_mid_goal_docks_charges_and_resumes_at_the_same_waypoint():
    r = Run(laps=1, dock=DOCK)
    r.start()
    r.battery(0.8)
    r.finish()                               # a reached
    out = r.battery(0.15, dt=3.0)            # mid-way to b
    assert isinstance(out[-1], cr.Cancel) and r.cruise.activity == cr.TO_DOCK
    assert "resume at lap 1, 'b'" in out[0].text
    r.finish(cr.PREEMPTED, dt=0.2)           # the cancel confirmed: to the dock
    assert r.sends() == ["a", "b", "dock"]
    assert r.cruise.status()[0] == cr.WARN and dict(r.cruise.status().values)["battery action"] == "going to the dock"
    r.feedback(-0.9, dt=19.0)                # beside the dock
    r.battery(0.04, dt=0.5)                  # below critical, but at the dock: no stop
    r.finish(dt=0.5)                         # docked
    assert r.cruise.activity == cr.CHARGING and r.cruise.dock_visits == 1
    assert dict(r.cruise.status().values)["battery action"] == "charging"
    r.battery(0.041, dt=1.0, status=cr.POWER_CHARGING)   # charging below critical: no stop
    assert not r.cruise.done
    for pct in (0.3, 0.6, 0.89):
        assert r.battery(pct, dt=10.0, status=cr.POWER_CHARGING) == []
    r.battery(0.9, dt=10.0, status=cr.POWER_CHARGING)    # charged: b again, same lap
    assert r.sends() == ["a", "b", "dock", "b"] and r.cruise.lap == 1
    r.finish()
    r.finish()
    s = r.summary()
    assert s["state"] == cr.COMPLETED and s["laps"] == 1 and s["reached"] == 3 and s["skipped"] == []
    assert s["dock_visits"] == 1 and s["low_battery_events"] == 1 and s["retries"] == 0
    assert any("'b' interrupted" in line for line in r.logs())


def dock_with_low_battery(max_retries=2, level=0.15):
    """A cruise parked at the dock (the dock goal reached) with the battery at level."""
    r = Run(laps=1, dock=DOCK, max_retries=max_retries)
    r.start()
    r.battery(level)
    r.finish(cr.PREEMPTED, dt=0.2)
    r.finish(dt=20.0)
    assert r.cruise.activity == cr.CHARGING
    return r


def test_a_charger_that_does_not_engage_sends_the_dock_goal_again_then_stops():
    """The dock goal was reached 0.35 m from the dock (xy_goal_tolerance plus amcl's
    error; the charger needs 0.3 m): the cruise waited for resume_battery while the
    battery ran flat, the critical stop disabled by "charging"."""
    r = dock_with_low_battery(max_retries=2)
    for arrival in (1, 2, 3):
        for _ in range(10):                   # 10 s of 1 Hz messages: discharging
            out = r.battery(r.cruise.percentage - 0.001, dt=1.0, status=cr.POWER_DISCHARGING)
        if arrival < 3:
            assert r.sends()[-1] == "dock" and r.sends().count("dock") == arrival + 1
            assert "the charger did not engage" in out[0].text and f"retry {arrival} of 2" in out[0].text
            assert r.cruise.activity == cr.TO_DOCK
            r.finish(dt=5.0)                  # at the dock again
    s = r.summary()
    assert s["state"] == cr.DOCK_UNREACHABLE and "the charger did not engage" in s["reason"]
    assert s["retries"] == 2 and s["dock_visits"] == 1 and r.cruise.status()[0] == cr.ERROR


def test_a_charger_that_engages_late_within_the_timeout_is_waited_for():
    r = dock_with_low_battery()
    r.battery(0.149, dt=1.0, status=cr.POWER_DISCHARGING)   # the status lags the arrival
    assert dict(r.cruise.status().values)["battery action"] == "waiting for the charger"
    for _ in range(20):
        assert r.battery(r.cruise.percentage + 0.005, dt=1.0, status=cr.POWER_CHARGING) == []
    assert r.sends()[-1] == "dock" and r.sends().count("dock") == 1
    out = r.battery(0.5, dt=1.0, status=cr.POWER_FULL)      # the charger says full: on
    assert r.sends()[-1] == "a" and "charged (50.0 %)" in out[0].text


def test_at_the_dock_without_the_charger_the_critical_stop_applies():
    r = Run(laps=1, dock=DOCK)
    r.start()
    r.battery(0.15)
    r.finish(cr.PREEMPTED, dt=0.2)
    r.feedback(-0.95, dt=30.0)               # beside the dock: below critical is no stop yet
    r.battery(0.045)
    r.finish(dt=1.0)
    for k in range(12):                      # the charger works: a level below critical is fine
        r.battery(0.045 + 0.0001 * k, dt=1.0, status=cr.POWER_CHARGING)
    assert not r.cruise.done and r.cruise.activity == cr.CHARGING
    out = r.battery(0.044, dt=1.0, status=cr.POWER_NOT_CHARGING)   # it stopped charging
    assert isinstance(out[-1], cr.Finish) and out[-1].summary["state"] == cr.CRITICAL


def test_charging_while_the_level_keeps_falling_is_not_charging():
    r = dock_with_low_battery()
    for _ in range(10):
        out = r.battery(r.cruise.percentage - 0.002, dt=1.0, status=cr.POWER_CHARGING)
    assert "the charger did not engage" in out[0].text and r.sends()[-1] == "dock"
    assert r.sends().count("dock") == 2


def test_a_driver_without_a_status_is_judged_by_the_level_rising():
    """power_supply_status UNKNOWN (a driver that never sets it): the charger works when
    the level rises over each charge_start_timeout, as before the status was read."""
    r = dock_with_low_battery()
    for _ in range(30):
        assert r.battery(r.cruise.percentage + 0.002, dt=1.0) == []
    assert r.sends().count("dock") == 1 and not r.cruise.done
    for _ in range(10):
        out = r.battery(r.cruise.percentage, dt=1.0)       # flat for a window: not charging
    assert "the charger did not engage" in out[0].text and "status unknown" in out[0].text


def test_a_waypoint_reached_while_the_battery_cancel_travels_counts_and_the_cruise_resumes_after_it():
    r = Run(laps=1, dock=DOCK)
    r.start()
    r.battery(0.1)
    r.finish(cr.SUCCEEDED)                   # a was reached before the cancel
    r.finish()                               # docked
    r.battery(0.95)
    assert r.sends() == ["a", "dock", "b"]
    assert r.cruise.log.reached == 1


def test_low_battery_at_the_start_goes_to_the_dock_first():
    r = Run(laps=1, dock=DOCK)
    r.battery(0.1)                           # before start: only remembered
    r.start()
    assert r.sends() == ["dock"]


def test_battery_levels_are_logged_with_one_decimal():
    """19.6 % was logged as "battery low (20 % < 20 %)": a level under the threshold
    printed as equal to it."""
    r = Run(laps=1, dock=DOCK)
    r.start()
    r.battery(0.196)
    assert "battery low (19.6 % < 20.0 %)" in r.logs(cr.WARN)[0]
    r.finish(cr.PREEMPTED)
    assert "charging to 90.0 %" in r.finish()[0].text
    assert "charged (90.4 %)" in r.battery(0.904)[0].text


def test_critical_battery_away_from_the_dock_stops_with_an_error():
    r = Run(laps=2, dock=DOCK)
    r.start()
    r.battery(0.5)
    r.finish()
    out = r.battery(0.04, dt=2.0)
    assert any(isinstance(c, cr.Cancel) for c in out)
    assert isinstance(out[-1], cr.Finish) and out[-1].summary["state"] == cr.CRITICAL
    assert r.logs(cr.ERROR) and "critical" in r.logs(cr.ERROR)[0]
    assert r.cruise.status()[0] == cr.ERROR
    assert r.finish() == []                  # the canceled goal's late answer changes nothing
    assert r.tick(100.0) == []


def test_critical_battery_on_the_way_to_the_dock_stops_too():
    r = Run(laps=1, dock=DOCK)
    r.start()
    r.battery(0.1)
    r.finish(cr.PREEMPTED)
    r.battery(0.03, dt=5.0)
    assert r.summary()["state"] == cr.CRITICAL


def test_an_unreachable_dock_stops_safely():
    r = Run(laps=1, dock=DOCK, max_retries=1)
    r.start()
    r.battery(0.1)
    r.finish(cr.PREEMPTED)
    r.finish(cr.ABORTED, "no path to the dock")
    r.tick(1.5)                              # the retry, after clearing the costmaps
    assert r.sends() == ["a", "dock", "dock"]
    out = r.finish(cr.ABORTED, "no path to the dock")
    s = out[-1].summary
    assert s["state"] == cr.DOCK_UNREACHABLE and "no path to the dock" in s["reason"]
    assert s["dock_visits"] == 0 and r.cruise.status()[0] == cr.ERROR
    assert r.tick(10.0) == [] and r.battery(0.95) == []


def test_no_battery_topic_warns_once_and_cruises_then_picks_the_battery_up():
    r = Run(laps=1, dock=DOCK)
    r.start()
    r.tick(4.0)
    assert r.logs(cr.WARN) == []
    r.tick(2.0)
    r.tick(2.0)
    assert len(r.logs(cr.WARN)) == 1 and "no battery data" in r.logs(cr.WARN)[0]
    assert dict(r.cruise.status().values)["battery action"] == "no battery data"
    r.finish()
    r.finish()
    assert r.sends() == ["a", "b", "c"]
    out = r.battery(0.1)                      # it appears: handled from now on
    assert "battery data arrived" in out[0].text and isinstance(out[-1], cr.Cancel)


def test_low_battery_without_a_dock_only_warns_once():
    r = Run(laps=1)
    r.start()
    r.battery(0.1)
    r.battery(0.1)
    assert len(r.logs(cr.WARN)) == 1 and "no dock" in r.logs(cr.WARN)[0]
    r.finish(); r.finish(); r.finish()
    assert r.summary()["state"] == cr.COMPLETED


def test_a_bad_entry_is_skipped_every_lap_with_its_reason():
    bad = cr.Stop("ghost", None, error="unknown label 'ghost'")
    r = Run(stops=(A, bad, B), laps=2)
    r.start()
    for _ in range(4):
        r.finish()
    s = r.summary()
    assert [k["lap"] for k in s["skipped"]] == [1, 2] and s["skipped"][0]["waypoint"] == "ghost"
    assert s["reached"] == 4 and s["laps"] == 2


def test_only_bad_entries_stop_instead_of_looping():
    bad = cr.Stop("ghost", None, error="unknown label")
    r = Run(stops=(bad,), laps=0)
    out = r.start()
    assert out[-1].summary["state"] == cr.STOPPED


def test_return_home_interrupts_and_ends_stopped():
    home = cr.Stop("home", Spot.from_xy_yaw(0.0, 0.0, 0.0))
    r = Run(laps=0, home=home)
    r.start()
    accepted, out = r.cruise.return_home(r.t)
    r.do(out)
    assert accepted and isinstance(out[-1], cr.Cancel)
    r.finish(cr.PREEMPTED)
    assert r.sends() == ["a", "home"]
    r.finish()
    assert r.summary()["state"] == cr.STOPPED and r.cruise.lap == 1
    assert "patrol done: 1 round(s)" in r.cruise.log.summary(r.cruise.lap, 0.0)
    assert cr.Cruise([A]).return_home(0.0)[0] is False    # no home


def test_a_stop_reached_while_return_home_cancels_it_counts_as_reached():
    """CI at cc35eb9 (patrol_blocked.test, the simulator at 1.35x of 4x): move_base reported
    turtle SUCCEEDED, the test saw that and called ~return_home, and the patrol handled the
    request before the goal's result. The cancel came too late, the goal had succeeded, and
    the summary said 'reached 2' for three stops reached. A goal that succeeds while the
    cancel is on its way is reached, as when the battery interrupts it."""
    home = cr.Stop("home", Spot.from_xy_yaw(0.0, 0.0, 0.0))
    r = Run(laps=0, home=home)
    r.start()
    r.do(r.cruise.return_home(r.t)[1])
    r.finish(cr.SUCCEEDED)                       # the result of 'a', after the request
    assert r.sends() == ["a", "home"]
    r.finish()
    assert r.summary()["state"] == cr.STOPPED and r.summary()["reached"] == 1


def test_the_diagnostic_values():
    r = Run(laps=2, dock=DOCK)
    assert r.cruise.status().message == "waiting to start"
    r.start()
    r.battery(0.55)
    level, message, values = r.cruise.status()
    assert level == cr.OK and message == cr.CRUISING
    assert dict(values) == {"state": "cruising", "lap": "1 of 2", "waypoint": "a", "battery action": "none",
                      "battery percentage": "55.0", "dock visits": "0", "reached": "0", "skipped": "0"}


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="laps"):
        cr.Cruise([A], laps=-1)
    with pytest.raises(ValueError, match="critical_battery"):
        cr.Cruise([A], battery=cr.BatteryLimits(low=0.5, resume=0.4))
    with pytest.raises(ValueError, match="charge_start_timeout"):
        cr.Cruise([A], battery=cr.BatteryLimits(charge_start_timeout=0.0))


# -- the waypoint file ----------------------------------------------------------------------
def test_a_waypoint_file_with_a_dock_and_other_keys(tmp_path):
    path = tmp_path / "w.yaml"
    path.write_text("start: {x: 0, y: 0, yaw_deg: 0}\n"
                    "waypoints:\n  - {name: s1, x: 1.0, y: 2.0, yaw_deg: 90}\n  - {name: s2, x: 3, y: 4, yaw_deg: 0}\n"
                    "dock: {x: -1.0, y: 0.5, yaw_deg: 180}\n")
    stops, dock = cr.load_waypoints(str(path))
    assert [s.name for s in stops] == ["s1", "s2"] and stops[0].error is None
    assert math.isclose(stops[0].spot.yaw, math.pi / 2) and stops[1].spot.x == 3.0
    assert dock.name == "dock" and dock.spot.x == -1.0 and math.isclose(abs(dock.spot.yaw), math.pi)


def test_a_bad_waypoint_entry_is_kept_with_its_reason(tmp_path):
    path = tmp_path / "w.yaml"
    path.write_text("waypoints:\n  - {name: s1, x: 1.0, y: 2.0, yaw_deg: 90}\n  - {name: s2, x: 3}\n  - 7\n")
    stops, dock = cr.load_waypoints(str(path))
    assert dock is None and stops[0].error is None
    assert str(path) in stops[1].error and "waypoints[1] ('s2')" in stops[1].error
    assert "waypoints[2]" in stops[2].error


@pytest.mark.parametrize("text, match", [
    (None, "cannot read"),
    ("waypoints: [{name: a, x: 1", "not YAML"),
    ("laps: 3\n", "non-empty list 'waypoints"),
    ("waypoints: []\n", "non-empty list 'waypoints"),
    ("waypoints:\n  - {name: a, x: one, y: 0, yaw_deg: 0}\n", r"no usable waypoint.*waypoints\[0\] \('a'\)"),
    ("waypoints:\n  - {name: a, x: 1, y: 0, yaw_deg: 0}\ndock: {x: 1}\n", "dock"),
])
def test_a_waypoint_file_that_cannot_be_used_names_the_file_and_the_entry(tmp_path, text, match):
    path = tmp_path / "w.yaml"
    if text is not None:
        path.write_text(text)
    with pytest.raises(cr.WaypointFileError, match=match) as err:
        cr.load_waypoints(str(path))
    assert str(path) in str(err.value)
