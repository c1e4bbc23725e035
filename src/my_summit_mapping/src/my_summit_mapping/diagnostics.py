"""slam_gmapping's diagnostic checks (pure): how long the particle filter takes a scan.

gmapping itself publishes no diagnostics; an operator of a mapping run wants to know that
the filter keeps up. The filter takes a scan in its own thread, from a queue (see the
node): an update that takes longer than map_update_interval [s] means the map lags the
robot by more than the interval it was asked for, and scans dropped from the filter's
full queue are scans the map never sees. The scan-rate check is
summit_nav_common.diagnostic_checks.scan_rate_check.
"""
import threading

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


def map_update_check(last: float, longest: float, count: int, map_update_interval: float,
                     pending: int, dropped_new: int) -> Check:
    """The filter's update time. last / longest [s]: wall time of the latest and the
    longest update (last None before the first); count: updates so far;
    map_update_interval [s]; pending: scans waiting for the filter; dropped_new: scans
    dropped from its full queue since the previous report.
    WARN when the latest update took longer than map_update_interval or scans were dropped."""
    values = (("last update time [s]", fmt(float(last or 0.0))),
              ("max update time [s]", fmt(float(longest))),
              ("updates", fmt(int(count))),
              ("map_update_interval [s]", fmt(float(map_update_interval))),
              ("scans waiting", fmt(int(pending))))
    if dropped_new > 0:
        return Check(WARN, f"{dropped_new} scan(s) dropped from the filter's full queue since the last "
                           "report: the filter falls behind", values)
    if last is None:
        return Check(OK, "no filter update yet", values)
    if last > map_update_interval:
        return Check(WARN, f"the last update took {last:.2f} s, longer than map_update_interval "
                           f"{map_update_interval:g} s", values)
    return Check(OK, f"last update {last:.3f} s", values)
