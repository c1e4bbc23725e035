"""slam_gmapping's diagnostic checks (pure): whether the particle filter keeps up.

gmapping itself publishes no diagnostics; an operator of a mapping run wants to know that
the filter keeps up. The filter takes the scans in its own thread, from a queue (see the
node), so falling behind shows in ROS time, the clock of the scans' stamps (simulated
under a simulator at any ~speed): the lag is now minus the stamp of the scan the filter
took last, while scans wait for it (none waiting: it has caught up). A lag beyond
map_update_interval [s of ROS time] means the map it serves is older than the period it
was asked to be regenerated at; scans dropped from its full queue are scans the map never
sees. The wall time an update takes depends on the machine and is reported as a value
only. The scan-rate check is summit_nav_common.diagnostic_checks.scan_rate_check.
"""
import threading
from typing import Optional

from summit_nav_common.diagnostic_checks import OK, WARN, Check, fmt

SCAN_TIMEOUT = 15.0   # [s] no scan for this long is an ERROR (as amcl's laser check)
HARDWARE_ID = "none"  # a software node: no device (diagnostic_updater's convention)


class UpdateTimes:
    """Wall-clock durations of the filter's updates: add(seconds) from the filter's
    thread, read() from the diagnostics' (last, max, count, dropped-so-far)."""

    def __init__(self):
        self._lock = threading.Lock()
        self.last = None    # [s] the latest update
        self.max = 0.0      # [s] the longest update
        self.count = 0

    def add(self, seconds: float) -> None:
        with self._lock:
            self.last = seconds
            self.max = max(self.max, seconds)
            self.count += 1

    def read(self):
        with self._lock:
            return self.last, self.max, self.count


def filter_lag(now: float, last_taken: Optional[float], oldest_waiting: Optional[float]) -> float:
    """How far the filter is behind [s of ROS time]: now minus the stamp of the scan it
    took last (before the first: of the oldest scan waiting), 0 when no scan waits for it
    (queued or being taken). now, last_taken, oldest_waiting: ROS time [s]."""
    if oldest_waiting is None:
        return 0.0
    since = last_taken if last_taken is not None else oldest_waiting
    return max(0.0, now - since)


def map_update_check(lag: float, max_lag: float, pending: int, dropped_new: int,
                     last_wall: Optional[float], longest_wall: float, count: int) -> Check:
    """Whether the filter keeps up with the scans.

    lag [s of ROS time]: filter_lag; max_lag [s of ROS time]: the lag allowed (the node's
    map_update_interval); pending: scans waiting for the filter; dropped_new: scans
    dropped from its full queue since the previous report; last_wall / longest_wall
    [s of wall time]: the latest and the longest filter update (last None before the
    first), reported only; count: updates so far.
    WARN when scans were dropped or the lag exceeds max_lag.
    """
    values = (("lag [s]", fmt(float(lag))),
              ("max lag [s] (map_update_interval)", fmt(float(max_lag))),
              ("scans waiting", fmt(int(pending))),
              ("updates", fmt(int(count))),
              ("last update wall time [s]", fmt(float(last_wall)) if last_wall is not None else "n/a"),
              ("max update wall time [s]", fmt(float(longest_wall)) if count else "n/a"))
    if dropped_new > 0:
        return Check(WARN, f"{dropped_new} scan(s) dropped from the filter's full queue since the last "
                           "report: the filter falls behind", values)
    if lag > max_lag:
        return Check(WARN, f"the filter is {lag:.1f} s behind the scans, more than map_update_interval "
                           f"{max_lag:g} s ({pending} waiting)", values)
    if count == 0:
        return Check(OK, "no filter update yet", values)
    return Check(OK, f"{lag:.2f} s behind the scans", values)
