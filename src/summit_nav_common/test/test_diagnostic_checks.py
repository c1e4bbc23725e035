"""summit_nav_common.diagnostic_checks: the rate meter and the scan-rate check's levels."""
import pytest

from summit_nav_common.diagnostic_checks import (ERROR, OK, WARN, RateMeter, RateReading, ScanMonitor, fmt,
                                                 scan_rate_check)


def test_fmt_writes_numbers_as_cpp_ostream():
    assert fmt(0.2) == "0.2"
    assert fmt(0.0223606797749979) == "0.0223607"
    assert fmt(1e-5) == "1e-05"
    assert fmt(3) == "3"
    assert fmt(True) == "True"
    assert fmt(float("nan")) == "nan"


def test_rate_meter_measures_intervals_between_ticks():
    m = RateMeter()
    for k in range(41):
        m.tick(10.0 + k * 0.025)
    r = m.read()
    assert r.rate == pytest.approx(40.0)
    assert r.events == 41
    assert r.last == pytest.approx(11.0)
    # a new window: nothing since the read, the last event is kept
    r = m.read()
    assert r.rate is None and r.events == 0 and r.last == pytest.approx(11.0)


def test_rate_meter_counts_the_interval_across_a_read():
    m = RateMeter()
    m.tick(0.0)
    m.read()
    m.tick(0.5)
    assert m.read().rate == pytest.approx(2.0)


def test_rate_meter_restart_leaves_out_the_idle_gap():
    m = RateMeter()
    for k in range(11):
        m.tick(k * 0.1)          # 10 Hz for 1 s
    m.restart()
    for k in range(11):
        m.tick(100.0 + k * 0.1)  # 99 s idle, then 10 Hz again
    assert m.read().rate == pytest.approx(10.0)


def test_rate_meter_time_going_back_starts_a_new_sequence():
    m = RateMeter()
    m.tick(50.0)
    m.tick(1.0)   # the simulator restarted its clock
    m.tick(1.5)
    assert m.read().rate == pytest.approx(2.0)


def reading(rate, events=40, last=99.9):
    return RateReading(rate, events, last)


def test_scan_rate_ok_at_the_lasers_rate():
    c = scan_rate_check(reading(39.5), 40.0, 0, 0, now=100.0, timeout=15.0)
    assert c.level == OK
    values = dict(c.values)
    assert values["rate [Hz]"] == "39.5" and values["expected rate [Hz]"] == "40"


def test_scan_rate_warns_below_90_percent():
    c = scan_rate_check(reading(35.0), 40.0, 0, 0, now=100.0, timeout=15.0)
    assert c.level == WARN and "below 90%" in c.message


def test_scan_rate_warns_on_skipped_scans():
    c = scan_rate_check(reading(40.0), 40.0, 7, 3, now=100.0, timeout=15.0)
    assert c.level == WARN and "3 scan(s) skipped" in c.message
    assert dict(c.values)["scans skipped"] == "7"


def test_scan_rate_unknown_scanner_rate_only_checks_skips():
    assert scan_rate_check(reading(5.0), None, 0, 0, now=100.0, timeout=15.0).level == OK


def test_scan_rate_no_scan_yet_warns_and_a_silent_laser_is_an_error():
    c = scan_rate_check(RateReading(None, 0, None), 40.0, 0, 0, now=3.0, timeout=15.0, topic="/scan")
    assert c.level == WARN and "no scan received yet on /scan" == c.message
    c = scan_rate_check(RateReading(None, 0, 80.0), 40.0, 0, 0, now=100.0, timeout=15.0)
    assert c.level == ERROR and "no scan for 20.0 s" in c.message


def test_scan_rate_one_scan_in_a_window_warns():
    c = scan_rate_check(RateReading(None, 1, 99.0), 40.0, 0, 0, now=100.0, timeout=15.0)
    assert c.level == WARN and "fewer than two" in c.message


def test_scan_monitor_reports_new_skips_once():
    mon = ScanMonitor("/scan", timeout=15.0)
    for k in range(41):
        mon.scan(k * 0.025, 0.025)
    assert mon.check(1.0, skipped_total=2).level == WARN
    for k in range(41, 81):
        mon.scan(k * 0.025, 0.025)
    c = mon.check(2.0, skipped_total=2)
    assert c.level == OK, c.message
