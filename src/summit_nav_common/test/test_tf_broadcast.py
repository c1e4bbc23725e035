"""The map -> odom broadcaster thread (summit_nav_common.ros.tf_broadcast) of slam_gmapping
and slam_karto.

At shutdown: rospy closes the node's publishers when it shuts down, and the thread can be
between its `rospy.is_shutdown()` check and the publish: that publish raises "publish() to
a closed topic". The thread must end quietly then (CI printed the traceback on a Ctrl-C,
twice), and still raise when the topic is closed while the node is running.

rospy.core.signal_shutdown sets is_shutdown_requested(), runs the pre-shutdown hooks (the
registration manager's cleanup closes every topic there) and only then sets
is_shutdown(): the fake below keeps that order, and a check of is_shutdown() alone fails.
"""
import math

import pytest
import rospy

from summit_nav_common.ros import tf_broadcast


class _ClosingPublisher:
    """Takes `good` messages (their transforms copied), then raises as a closed publisher does."""

    def __init__(self, good, on_close):
        self.good, self.sent, self.on_close = good, [], on_close

    def publish(self, msg):
        if len(self.sent) == self.good:
            self.on_close()
            raise rospy.ROSException("publish() to a closed topic")
        t = msg.transforms[0]
        self.sent.append((t.header.stamp.to_sec(), t.header.frame_id, t.child_frame_id, t.transform.translation.x,
                          t.transform.rotation.z, t.transform.rotation.w))


@pytest.fixture
def fake_ros(monkeypatch):
    """A clock that ticks 0.01 s every second read (a repeated stamp is not sent), no waiting."""
    ticks = iter(range(1, 10 ** 6))
    monkeypatch.setattr(tf_broadcast, "_now_ns", lambda: 10 ** 7 * (next(ticks) // 2))
    monkeypatch.setattr(tf_broadcast, "_wait_until", lambda due, now: None)
    monkeypatch.setattr(rospy, "is_shutdown", lambda: False)


def _broadcaster(monkeypatch, publisher, listener=None):
    monkeypatch.setattr(tf_broadcast.rospy, "Publisher", lambda *a, **k: publisher)
    return tf_broadcast.PeriodicTransform("map", "odom", 0.05, 0.2, lambda: (1.5, 0.0, math.pi / 2), listener)


def test_loop_ends_quietly_when_shutdown_closes_the_publisher(monkeypatch, fake_ros):
    state = {"requested": False}
    # the topics close while shutdown is requested and is_shutdown() is still False
    monkeypatch.setattr(rospy.core, "is_shutdown_requested", lambda: state["requested"])
    pub = _ClosingPublisher(3, on_close=lambda: state.update(requested=True))
    owned = []
    listener = type("L", (), {"own": lambda self, t: owned.append(t.header.stamp.to_sec())})()
    b = _broadcaster(monkeypatch, pub, listener)
    b.run()   # returns, no exception
    assert b.sent == 3 and len(pub.sent) == 3
    # each stamped now + tolerance, on the 0.05 s grid, the pose as given; into the buffer too
    stamps = [s[0] for s in pub.sent]
    assert stamps == pytest.approx([0.2, 0.25, 0.3]) and owned == pytest.approx(stamps)
    assert pub.sent[0][1:] == pytest.approx(("map", "odom", 1.5, math.sqrt(0.5), math.sqrt(0.5)))


def test_loop_still_raises_a_closed_topic_while_running(monkeypatch, fake_ros):
    monkeypatch.setattr(rospy.core, "is_shutdown_requested", lambda: False)
    with pytest.raises(rospy.ROSException, match="closed topic"):
        _broadcaster(monkeypatch, _ClosingPublisher(2, on_close=lambda: None)).run()


def test_period_must_be_positive(monkeypatch):
    with pytest.raises(ValueError, match="period"):
        tf_broadcast.PeriodicTransform("map", "odom", 0.0, 0.0, lambda: (0, 0, 0))


def test_sends_on_the_period_grid_as_ros_rate(monkeypatch):
    """A 100 Hz clock (0.01 s steps), period 0.05 s: every fifth tick, on the grid; a stall of
    a second starts the grid again from then (no burst to catch up); a clock set back (a
    bag played again) starts it again there."""
    clock = [0.0, 0.01, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.1, 0.11,
             1.13, 1.14, 1.15, 1.16, 1.17, 1.18, 1.19,
             0.30, 0.31, 0.32, 0.33, 0.34, 0.35, 0.36]
    reads = iter(clock)
    stop = {"now": False}

    def now_ns():
        try:
            return int(round(next(reads) * 1e9))
        except StopIteration:
            stop["now"] = True
            return int(round(clock[-1] * 1e9))
    monkeypatch.setattr(tf_broadcast, "_now_ns", now_ns)
    monkeypatch.setattr(tf_broadcast, "_wait_until", lambda due, now: None)
    monkeypatch.setattr(rospy, "is_shutdown", lambda: stop["now"])
    pub = _ClosingPublisher(10 ** 6, on_close=lambda: None)
    _broadcaster(monkeypatch, pub).run()
    stamps = [round(s[0] - 0.2, 2) for s in pub.sent]
    assert stamps == [0.0, 0.05, 0.1, 1.13, 1.18, 0.3, 0.35]
