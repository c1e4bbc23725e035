"""Waiting for a ROS time without waking at every /clock message.

rospy.sleep and rospy.Rate wait on rospy's clock condition, which each /clock message
notifies: a thread waiting for a second of simulated time wakes at every message (a bag
played by rosbag play sends 100 per wall second), and each time builds and compares a few
genpy Times. slam_karto's diagnostics timer, ticking every 0.1 s of ROS time, took about
15 % of the node's CPU on the Intel bag at rate 4 (py-spy). Here a wait that is long
enough sleeps in wall time for most of it, at the rate the simulated clock has been
running in this process, and waits on the condition only for the last part.
"""
import threading
import time

import rospy
import rospy.rostime

LEAD = 0.03       # [s of wall time] the end of a wait is waited for on the clock condition
SHARE = 0.8       # of the wall time a wait is expected to take, at most this much is slept
RATE_WINDOW = 0.2  # [s of wall time] the shortest span the clock's rate is measured over


def now_ns():
    """ROS time now [ns] (integers: genpy Times cost more to build and compare)."""
    now = rospy.rostime.get_rostime()
    return now.secs * 10 ** 9 + now.nsecs


class ClockRate:
    """How fast ROS time runs against wall time [s per s], from readings of both: the
    oldest reading kept is replaced once it is 2 s old; time going back starts over."""

    def __init__(self, wall=time.monotonic):
        self._wall = wall
        self._lock = threading.Lock()
        self._ref = None   # (wall [s], ROS time [ns]) of the oldest reading kept
        self._last = None  # ROS time [ns] of the latest reading

    def read(self, ros_ns):
        """A reading of ROS time ros_ns [ns] now; returns the rate, or None while unknown."""
        wall = self._wall()
        with self._lock:
            back = self._last is not None and ros_ns < self._last
            self._last = ros_ns
            if self._ref is None or back:
                self._ref = (wall, ros_ns)
                return None
            span = wall - self._ref[0]
            if span < RATE_WINDOW:
                return None
            rate = (ros_ns - self._ref[1]) * 1e-9 / span
            if span > 2.0:
                self._ref = (wall, ros_ns)
            return rate


_RATE = ClockRate()


def wait_until(due_ns, timeout=0.5):
    """Wait until ROS time due_ns [ns], for at most timeout [s] of wall time; may return
    earlier (the next /clock message, a wall sleep that ends short of it): the caller
    reads the time again and decides."""
    if rospy.rostime.is_wallclock():
        time.sleep(min(timeout, max(0.0, (due_ns - now_ns()) * 1e-9)))
        return
    now = now_ns()
    if now >= due_ns:
        return
    rate = _RATE.read(now)
    if rate is not None and rate > 0.0:
        wall = (due_ns - now) * 1e-9 / rate
        if wall > LEAD / (1.0 - SHARE):
            time.sleep(min(timeout, SHARE * wall))
            return
    cond = rospy.rostime.get_rostime_cond()
    with cond:
        if now_ns() < due_ns:
            cond.wait(timeout)
