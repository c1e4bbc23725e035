"""Waiting in a rostest node: a topic's latest message, simulated time, /rosout lines.

Every wait is bounded in wall-clock time (a loaded machine runs the simulator slower
than asked, so a bound in simulated time alone could wait for ever) and fails with an
AssertionError that names what it waited for.
"""
import threading
import time

import rospy

WALL_TIMEOUT = 60.0   # [s] default wall-clock bound of a wait


def wait_for(condition, what, timeout_wall=WALL_TIMEOUT, poll=0.02):
    """Block until condition() is true (polled every poll [s] wall); AssertionError
    naming `what` after timeout_wall [s] or at shutdown."""
    end = time.monotonic() + timeout_wall
    while not condition():
        if time.monotonic() > end or rospy.is_shutdown():
            raise AssertionError(f"no {what} within {timeout_wall:.0f} s")
        time.sleep(poll)


def wait_clock(timeout_wall=WALL_TIMEOUT):
    """Wait until /clock has started (simulated time > 0)."""
    wait_for(lambda: rospy.Time.now().to_sec() > 0.0, "/clock", timeout_wall)


def sleep_sim(seconds):
    """Sleep `seconds` [s] of simulated time."""
    rospy.sleep(rospy.Duration.from_sec(seconds))


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

    def wait(self, timeout_wall=WALL_TIMEOUT, after=0):
        """Block until more than `after` messages have arrived (by default: a first one);
        returns the last; AssertionError on timeout."""
        return self._wait_for(lambda m, n: n > after, f" after the first {after}" if after else "", timeout_wall)


class RosoutWatcher:
    """Collects (node name, text) of every /rosout message (thread-safe)."""

    def __init__(self):
        from rosgraph_msgs.msg import Log
        self.lines = []
        self.lock = threading.Lock()
        self.sub = rospy.Subscriber("/rosout", Log, self._cb, queue_size=200)

    def _cb(self, msg):
        with self.lock:
            self.lines.append((msg.name, msg.msg))

    def mark(self):
        """Index of the next line (to look only at what comes after)."""
        with self.lock:
            return len(self.lines)

    def find(self, node, text, start=0):
        """First line of `node` containing `text` from index start, or None."""
        with self.lock:
            for name, line in self.lines[start:]:
                if name.lstrip("/") == node and text in line:
                    return line
        return None

    def wait(self, node, text, start=0, timeout_wall=WALL_TIMEOUT):
        """Wait for a line of `node` containing `text`; returns it."""
        wait_for(lambda: self.find(node, text, start) is not None, f"'{text}' from {node} on /rosout",
                 timeout_wall)
        return self.find(node, text, start)
