"""slam_gmapping's "Map update" check levels and the filter's lag.

The check used to compare the wall time of the latest filter update with
map_update_interval, which is in ROS (simulated) seconds and is gmapping's map-regeneration
period, not a per-scan budget: at 4x a filter 2 s of wall time behind was 8 s of the
robot's motion behind yet OK, and one slow update with nothing queued warned. It now
judges the lag in ROS time (now minus the stamp of the scan taken last, while scans wait)
and reports the wall times as values only.
"""
from my_summit_mapping.diagnostics import UpdateTimes, filter_lag, map_update_check
from summit_nav_common.diagnostic_checks import OK, WARN


def test_no_update_yet_is_ok():
    c = map_update_check(0.0, 5.0, 0, 0, None, 0.0, 0)
    assert (c.level, c.message) == (OK, "no filter update yet")
    assert dict(c.values)["last update wall time [s]"] == "n/a"


def test_a_filter_keeping_up_is_ok_with_its_wall_times():
    c = map_update_check(0.1, 5.0, 3, 0, 0.12, 0.8, 42)
    assert c.level == OK
    assert dict(c.values) == {"lag [s]": "0.1", "max lag [s] (map_update_interval)": "5", "scans waiting": "3",
                              "updates": "42", "last update wall time [s]": "0.12",
                              "max update wall time [s]": "0.8"}


def test_a_slow_update_in_wall_time_is_only_a_value_when_the_filter_keeps_up():
    # 1.5 s of wall time for an update, map_update_interval 1 s, but nothing behind
    c = map_update_check(filter_lag(50.0, 49.9, None), 1.0, 0, 0, 1.5, 1.5, 10)
    assert c.level == OK and dict(c.values)["last update wall time [s]"] == "1.5"


def test_a_lag_beyond_map_update_interval_in_ros_time_warns():
    # fast updates in wall time, but at 4x the queue holds 6 s of scans
    lag = filter_lag(now=106.0, last_taken=100.0, oldest_waiting=100.025)
    assert lag == 6.0
    c = map_update_check(lag, 5.0, 240, 0, 0.3, 0.4, 80)
    assert c.level == WARN
    assert "6.0 s behind the scans, more than map_update_interval 5 s (240 waiting)" in c.message


def test_a_slow_first_update_is_forgotten_once_the_filter_caught_up():
    # the max keeps the slow one; the level follows the lag
    assert map_update_check(0.05, 5.0, 0, 0, 0.1, 9.0, 10).level == OK


def test_dropped_scans_warn():
    c = map_update_check(0.5, 5.0, 2400, 12, 0.1, 0.1, 10)
    assert c.level == WARN and "12 scan(s) dropped" in c.message


def test_filter_lag():
    assert filter_lag(10.0, 9.0, None) == 0.0           # nothing waits: caught up
    assert filter_lag(10.0, 9.0, 9.025) == 1.0          # since the scan taken last
    assert filter_lag(10.0, None, 7.5) == 2.5           # before the first: the oldest waiting
    assert filter_lag(10.0, 10.5, 10.6) == 0.0          # stamps ahead of now (tf delay): not negative


def test_update_times():
    t = UpdateTimes()
    assert t.read() == (None, 0.0, 0)
    t.add(0.3)
    t.add(0.1)
    assert t.read() == (0.1, 0.3, 2)
