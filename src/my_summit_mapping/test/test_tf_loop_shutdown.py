"""slam_gmapping's map->odom broadcaster thread at shutdown.

rospy closes the node's publishers when it shuts down, and the thread can be between its
`rospy.is_shutdown()` check and the publish: that publish raises "publish() to a closed
topic". The thread must end quietly then (CI printed the traceback on a Ctrl-C, twice),
and still raise when the topic is closed while the node is running.

rospy.core.signal_shutdown sets is_shutdown_requested(), runs the pre-shutdown hooks (the
registration manager's cleanup closes every topic there) and only then sets
is_shutdown(): the fake below keeps that order, and a check of is_shutdown() alone fails.
"""
import threading
import types
from pathlib import Path

import numpy as np
import pytest
import rospy

from summit_nav_common.testing.nodes import load_node_module

NODE = Path(__file__).resolve().parents[1] / "nodes" / "slam_gmapping"


def _load_node_module():
    return load_node_module(NODE, "slam_gmapping_node")


class _ClosingBroadcaster:
    """Sends `good` transforms, then raises as a closed publisher does."""

    def __init__(self, good, on_close):
        self.good, self.sent, self.on_close = good, 0, on_close

    def sendTransform(self, _t):
        if self.sent == self.good:
            self.on_close()
            raise rospy.ROSException("publish() to a closed topic")
        self.sent += 1


class _Rate:
    def __init__(self, _hz):
        pass

    def sleep(self):
        pass


def _node(module, broadcaster):
    node = module.SlamGmappingNode.__new__(module.SlamGmappingNode)
    node.config = types.SimpleNamespace(transform_publish_period=0.05, map_frame="map",
                                        odom_frame="odom", tf_delay=0.05)
    node.lock = threading.Lock()
    node.map_to_odom = np.zeros(3)
    node.tf_pub = broadcaster
    return node


@pytest.fixture
def fake_clock(monkeypatch):
    """A clock that ticks on each read, so each loop pass has a new stamp."""
    ticks = iter(range(1, 10 ** 6))
    monkeypatch.setattr(rospy.Time, "now", staticmethod(lambda: rospy.Time(next(ticks))))
    monkeypatch.setattr(rospy, "Rate", _Rate)


def test_tf_loop_ends_quietly_when_shutdown_closes_the_publisher(monkeypatch, fake_clock):
    module = _load_node_module()
    state = {"requested": False}
    # the topics close while shutdown is requested and is_shutdown() is still False
    monkeypatch.setattr(rospy, "is_shutdown", lambda: False)
    monkeypatch.setattr(rospy.core, "is_shutdown_requested", lambda: state["requested"])
    broadcaster = _ClosingBroadcaster(3, on_close=lambda: state.update(requested=True))
    _node(module, broadcaster).publish_tf_loop()   # returns, no exception
    assert broadcaster.sent == 3


def test_tf_loop_still_raises_a_closed_topic_while_running(monkeypatch, fake_clock):
    module = _load_node_module()
    monkeypatch.setattr(rospy, "is_shutdown", lambda: False)
    monkeypatch.setattr(rospy.core, "is_shutdown_requested", lambda: False)
    broadcaster = _ClosingBroadcaster(2, on_close=lambda: None)
    with pytest.raises(rospy.ROSException, match="closed topic"):
        _node(module, broadcaster).publish_tf_loop()
