"""A node's /diagnostics: Debian's diagnostic_updater.Updater, ticked in ROS time.

    diag = NodeDiagnostics(hardware_id="none")
    diag.add("Scan rate", lambda now: scan_rate_check(...))   # now: ROS time [s]

Each check is a function of the ROS time [s] returning a summit_nav_common.
diagnostic_checks.Check (pure, unit-tested); it runs in the updater's publication, once per
~diagnostic_period [s] (default 1, re-read by the Updater as the real one does), and is
published on /diagnostics as "<node name>: <check name>" (the Updater's prefix, which the
aggregator's GenericAnalyzers match with startswith). The Python Updater publishes only
when update() is called: a thread calls it when the period is up in ROS time, so the
publication follows the simulated clock as every other period of the nodes does, and
waits in between with rostime_wait (a rospy.Timer ticking every 0.1 s woke at every
/clock message and cost slam_karto about 15 % of its CPU). A check that raises is
published as ERROR with the exception and logged once, and the thread goes on.
"""
import threading

import diagnostic_updater
import rospy

from ..diagnostic_checks import ERROR
from . import rostime_wait
from .shutdown import publish_or_end


class NodeDiagnostics:
    def __init__(self, hardware_id: str = "none"):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(hardware_id)
        self._failed = set()
        self._stop = threading.Event()
        threading.Thread(target=self._run, name="diagnostics", daemon=True).start()

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

    def _due_ns(self):
        """When the Updater's period is up [ns of ROS time]: now if the clock went back
        (a bag played again) past its last publication."""
        u = self.updater
        last = u.last_time.secs * 10 ** 9 + u.last_time.nsecs
        now = rostime_wait.now_ns()
        if now < last:
            u.last_time = rospy.Time(*divmod(now, 10 ** 9))
            return now
        return last + int(round(float(u.period) * 1e9))

    def _run(self):
        while not (rospy.is_shutdown() or self._stop.is_set()):
            if not publish_or_end(self.updater.update):
                return   # rospy's shutdown closed /diagnostics
            due = self._due_ns()
            start = rostime_wait.now_ns()
            while not (rospy.is_shutdown() or self._stop.is_set()):
                now = rostime_wait.now_ns()
                if now >= due or now < start:   # due, or the clock went back
                    break
                rostime_wait.wait_until(due)

    def shutdown(self):
        self._stop.set()
