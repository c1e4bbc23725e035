"""A node's /diagnostics: Debian's diagnostic_updater.Updater, ticked in ROS time.

    diag = NodeDiagnostics(hardware_id="none")
    diag.add("Scan rate", lambda now: scan_rate_check(...))   # now: ROS time [s]

Each check is a function of the ROS time [s] returning a summit_nav_common.
diagnostic_checks.Check (pure, unit-tested); it runs in the updater's publication, once per
~diagnostic_period [s] (default 1, re-read by the Updater as the real one does), and is
published on /diagnostics as "<node name>: <check name>" (the Updater's prefix, which the
aggregator's GenericAnalyzers match with startswith). The Python Updater publishes only
when update() is called: a rospy.Timer calls it every TICK of ROS time, so the
publication follows the simulated clock as every other period of the nodes does. A check
that raises is published as ERROR with the exception and logged once, and the timer goes
on.
"""
import diagnostic_updater
import rospy

from ..diagnostic_checks import ERROR
from .shutdown import publish_or_end

TICK = 0.1   # [s] ROS time between update() calls: the publication period's resolution


class NodeDiagnostics:
    def __init__(self, hardware_id: str = "none"):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(hardware_id)
        self._failed = set()
        self._timer = rospy.Timer(rospy.Duration(TICK), self._tick)

    def add(self, name: str, check) -> None:
        """Publish check(now [s]) -> Check as the status `name` (without the node prefix)."""
        def run(stat):
            try:
                c = check(rospy.Time.now().to_sec())
            except Exception as e:  # noqa: BLE001 - reported as ERROR, never silently
                if name not in self._failed:
                    self._failed.add(name)
                    rospy.logerr(f"{rospy.get_name()}: diagnostic check '{name}' failed: {type(e).__name__}: {e}")
                stat.summary(ERROR, f"check failed: {type(e).__name__}: {e}")
                return stat
            stat.summary(c.level, c.message)
            for key, value in c.values:
                stat.add(key, value)
            return stat
        self.updater.add(name, run)

    def _tick(self, _event):
        if not publish_or_end(self.updater.update):
            self._timer.shutdown()   # rospy's shutdown closed /diagnostics

    def shutdown(self):
        self._timer.shutdown()
