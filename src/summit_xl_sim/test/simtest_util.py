"""Helpers for the simulator's rostest nodes: wait in simulated time, latest messages."""
import math
import threading
import time

import rospy
from summit_nav_common.geometry import quaternion_to_yaw as yaw_of  # noqa: F401  (used by the tests)


class Latest:
    """Keeps the last message of a topic and counts messages (thread-safe); callback, if
    given, is also called with each message (outside the lock)."""

    def __init__(self, topic, msg_type, callback=None):
        self.msg, self.count = None, 0
        self.stamps = []  # header stamps [s] of every message, for rates in simulated time
        self.lock = threading.Lock()
        self.callback = callback
        # No queue limit: rospy drops all but the last queue_size messages of what piled up
        # in the socket while this node was starved, and the rates and counts here must
        # be the publisher's, not this node's share of the CPU.
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=None)

    def _cb(self, msg):
        with self.lock:
            self.msg = msg
            self.count += 1
            if hasattr(msg, "header"):
                self.stamps.append(msg.header.stamp.to_sec())
        if self.callback:
            self.callback(msg)

    def rate_between(self, t0, t1):
        """Messages per second of simulated time stamped within [t0, t1) [s]: independent
        of transport delays, unlike counting arrivals against this node's clock."""
        with self.lock:
            n = sum(1 for t in self.stamps if t0 <= t < t1)
        return n / (t1 - t0)

    def _wait_for(self, ready, what, timeout_wall):
        """Block until ready(last message, count) is true; returns that message,
        AssertionError naming what was awaited on timeout."""
        end = time.monotonic() + timeout_wall
        while True:
            with self.lock:
                msg, count = self.msg, self.count
            if msg is not None and ready(msg, count):
                return msg
            if time.monotonic() > end or rospy.is_shutdown():
                raise AssertionError(f"no message on {self.sub.name}{what} within {timeout_wall:.0f} s")
            time.sleep(0.01)

    def wait_newer(self, t, timeout_wall=30.0):
        """Block until a message stamped after simulated time t [s] arrives (one that shows
        what changed at t, however late this loaded machine delivers it); returns it."""
        return self._wait_for(lambda m, n: m.header.stamp.to_sec() > t, f" stamped after {t:.2f} s", timeout_wall)

    def wait(self, timeout_wall=60.0, after=0):
        """Block until more than `after` messages have arrived (by default: a first one);
        returns the last; AssertionError on timeout."""
        return self._wait_for(lambda m, n: n > after, f" after the first {after}" if after else "", timeout_wall)


def wait_clock(timeout_wall=30.0):
    """Wait until /clock has started (sim time > 0)."""
    end = time.monotonic() + timeout_wall
    while rospy.Time.now().to_sec() <= 0.0:
        if time.monotonic() > end:
            raise AssertionError("no /clock within %.0f s" % timeout_wall)
        time.sleep(0.02)


def sleep_sim(seconds):
    """Sleep in simulated time."""
    rospy.sleep(rospy.Duration.from_sec(seconds))
