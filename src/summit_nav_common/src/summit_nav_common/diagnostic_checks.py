"""Diagnostic checks without ROS: levels, the result of a check, a rate meter, the scan check.

A node's /diagnostics (diagnostic_msgs/DiagnosticStatus: a level, a message and key/value
strings, published through diagnostic_updater) is computed by pure functions that return
a Check; summit_nav_common.ros.diagnostics turns a Check into the status. So every level
of every check is unit-tested without a ROS master.

References: diagnostic_msgs/DiagnosticStatus (levels OK 0, WARN 1, ERROR 2, STALE 3);
diagnostic_updater's FrequencyStatus (events over a window against an expected rate with
a tolerance), which RateMeter and scan_rate_check follow, measured from the events' own
stamps so that a window that starts mid-stream does not read low.
"""
import threading
from typing import NamedTuple, Optional, Tuple

OK, WARN, ERROR, STALE = 0, 1, 2, 3
# The aggregator's words for a level (diagnostic_aggregator's valToMsg)
LEVEL_NAMES = {OK: "OK", WARN: "Warning", ERROR: "Error", STALE: "Stale"}

MIN_RATE_RATIO = 0.9   # a rate below 90 % of the expected one is a warning (FrequencyStatus's
                       # default tolerance is 10 %)


class Check(NamedTuple):
    """One check's result: level (OK..STALE), message, values ((key, text), ...)."""
    level: int
    message: str
    values: Tuple[Tuple[str, str], ...] = ()


def fmt(value) -> str:
    """A value as a DiagnosticStatus string: numbers as C++'s ostream writes a double (6
    significant digits, '%g'), as the real nodes' DiagnosticStatusWrapper::add does."""
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "%g" % value
    return str(value)


def worst(*checks: Check) -> int:
    """The highest level among checks."""
    return max(c.level for c in checks)


class RateReading(NamedTuple):
    rate: Optional[float]   # [Hz] over the intervals since the previous read; None: fewer than 2 events
    events: int             # events since the previous read
    last: Optional[float]   # [s] time of the latest event ever, None before the first


class RateMeter:
    """Events per second from the events' times, read once per report.

    tick(t) counts an event at time t [s] (a message stamp, or ROS time); the interval
    since the previous event counts unless restart() broke the sequence in between (the
    control loop idle between goals) or time went back. read() returns the rate over the
    intervals counted since the previous read and starts a new window. A tick is a few
    additions under a lock: nothing is allocated per event.
    """

    def __init__(self):
        self._lock = threading.Lock()
        self._events = 0
        self._intervals = 0
        self._span = 0.0      # [s] sum of the counted intervals
        self._prev = None     # [s] the previous event of the current sequence
        self._last = None     # [s] the latest event

    def tick(self, t: float) -> None:
        with self._lock:
            prev = self._prev
            if prev is not None and t >= prev:
                self._intervals += 1
                self._span += t - prev
            self._prev = self._last = t
            self._events += 1

    def restart(self) -> None:
        """The next event starts a new sequence (the gap before it is not an interval)."""
        with self._lock:
            self._prev = None

    def read(self) -> RateReading:
        with self._lock:
            rate = self._intervals / self._span if self._intervals and self._span > 0.0 else None
            reading = RateReading(rate, self._events, self._last)
            self._events = self._intervals = 0
            self._span = 0.0
        return reading


def scan_rate_check(reading: RateReading, expected_hz: Optional[float], skipped_total: int,
                    skipped_new: int, now: float, timeout: float, topic: str = "scan",
                    min_ratio: float = MIN_RATE_RATIO) -> Check:
    """Laser scans received per second against the scanner's rate.

    reading: a RateMeter over the scans' stamps [s]; expected_hz: 1 / the scans'
    scan_time [Hz] (None or 0: unknown); skipped_total / skipped_new: scans lost (gaps in
    header.seq and scans the node dropped) in all and since the previous report; now [s]
    on the stamps' clock; timeout [s]: no scan for this long is an ERROR.
    WARN: no scan yet, scans skipped since the last report, fewer than two scans in the
    window, or a rate below min_ratio x expected.
    """
    age = None if reading.last is None else max(0.0, now - reading.last)
    values = (("rate [Hz]", fmt(float(reading.rate or 0.0))),
              ("expected rate [Hz]", fmt(float(expected_hz or 0.0))),
              ("scans in window", fmt(reading.events)),
              ("scans skipped", fmt(int(skipped_total))),
              ("last scan age [s]", fmt(float(age)) if age is not None else "never"))
    if age is None:
        return Check(WARN, f"no scan received yet on {topic}", values)
    if age > timeout:
        return Check(ERROR, f"no scan for {age:.1f} s on {topic}", values)
    if skipped_new > 0:
        return Check(WARN, f"{skipped_new} scan(s) skipped since the last report: the node falls behind", values)
    if reading.rate is None:
        return Check(WARN, f"fewer than two scans on {topic} since the last report", values)
    if expected_hz and reading.rate < min_ratio * expected_hz:
        return Check(WARN, f"scans at {reading.rate:.1f} Hz, below {min_ratio:.0%} of the laser's "
                           f"{expected_hz:.1f} Hz", values)
    return Check(OK, f"{reading.rate:.1f} Hz", values)


class ScanMonitor:
    """A node's "Scan rate" check: scan(stamp, scan_time) in the scan callback, check(now,
    skipped_total) once per report (skipped_total: the node's count of scans lost, e.g.
    summit_nav_common.ros.scan_stats.ScanStats.skipped)."""

    def __init__(self, topic: str, timeout: float, min_ratio: float = MIN_RATE_RATIO):
        self.topic, self.timeout, self.min_ratio = topic, float(timeout), float(min_ratio)
        self.meter = RateMeter()
        self.scan_time = 0.0      # [s] the last scan's scan_time (the scanner's period)
        self._reported = 0        # skipped_total at the previous report

    def scan(self, stamp: float, scan_time: float) -> None:
        """One scan received: its header stamp [s] and scan_time [s]."""
        self.meter.tick(stamp)
        self.scan_time = scan_time

    def check(self, now: float, skipped_total: int) -> Check:
        new = max(0, skipped_total - self._reported)
        self._reported = skipped_total
        period = self.scan_time
        expected = 1.0 / period if period and period > 0.0 else None
        return scan_rate_check(self.meter.read(), expected, skipped_total, new, now, self.timeout,
                               self.topic, self.min_ratio)
