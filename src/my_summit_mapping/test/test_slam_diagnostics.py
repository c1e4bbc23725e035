"""slam_gmapping's "Map update" check levels."""
from my_summit_mapping.diagnostics import UpdateTimes, map_update_check
from summit_nav_common.diagnostic_checks import OK, WARN


def test_no_update_yet_is_ok():
    c = map_update_check(None, 0.0, 0, 5.0, 0, 0)
    assert (c.level, c.message) == (OK, "no filter update yet")


def test_fast_updates_are_ok_with_their_times():
    c = map_update_check(0.12, 0.8, 42, 5.0, 3, 0)
    assert c.level == OK
    assert dict(c.values) == {"last update time [s]": "0.12", "max update time [s]": "0.8", "updates": "42",
                              "map_update_interval [s]": "5", "scans waiting": "3"}


def test_an_update_longer_than_map_update_interval_warns():
    c = map_update_check(1.5, 1.5, 10, 1.0, 0, 0)
    assert c.level == WARN and "longer than map_update_interval 1 s" in c.message


def test_a_slow_first_update_is_forgotten_once_updates_are_fast():
    # the max keeps the slow one; the level follows the last
    assert map_update_check(0.1, 9.0, 10, 5.0, 0, 0).level == OK


def test_dropped_scans_warn():
    c = map_update_check(0.1, 0.1, 10, 5.0, 2400, 12)
    assert c.level == WARN and "12 scan(s) dropped" in c.message


def test_update_times():
    t = UpdateTimes()
    assert t.read() == (None, 0.0, 0)
    t.add(0.3)
    t.add(0.1)
    assert t.read() == (0.1, 0.3, 2)
