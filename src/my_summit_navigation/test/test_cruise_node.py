"""Unit tests of the cruise's ROS adapter (my_summit_navigation.cruise_node.CruiseNode)
without a ROS master: rospy's publishers, subscribers and clock, the move_base action
client and the diagnostics are replaced by fakes that record what the node does."""
import threading
from types import SimpleNamespace

import pytest
import rospy

from my_summit_navigation import cruise as cr
from my_summit_navigation import cruise_node as cn
from my_summit_localization.spots import Spot

A, B = (cr.Stop(n, Spot.from_xy_yaw(x, 0.0, 0.0)) for n, x in (("a", 1.0), ("b", 2.0)))
DOCK = cr.Stop("dock", Spot.from_xy_yaw(-1.0, 0.0, 0.0))
PARAMS = {"action": "move_base", "frame": "map", "max_retries": 2, "movement_timeout": 30.0,
          "battery_topic": "/battery_state", "battery": cr.BatteryLimits()}


class FakeClient:
    """move_base's action client: records the goals; on_wait runs while the node waits
    for the server (messages that arrive meanwhile)."""

    def __init__(self, _ns, _spec):
        self.goals, self.canceled, self.on_wait = [], 0, None

    def wait_for_server(self, _timeout):
        if self.on_wait:
            self.on_wait()
        return True

    def send_goal(self, goal, done_cb=None, active_cb=None, feedback_cb=None):
        self.goals.append(goal)

    def cancel_goal(self):
        self.canceled += 1

    def get_goal_status_text(self):
        return ""


class FakeDiagnostics:
    def __init__(self, hardware_id):
        self.hardware_id = hardware_id
        self.checks = {}
        self.updater = SimpleNamespace(force_update=lambda: None)

    def add(self, name, check):
        self.checks[name] = check


@pytest.fixture
def ros(monkeypatch):
    """rospy without a master: fakes for what CruiseNode touches; the loop runs once."""
    warnings = []
    monkeypatch.setattr(cn, "SimpleActionClient", FakeClient)
    monkeypatch.setattr(cn, "NodeDiagnostics", FakeDiagnostics)
    monkeypatch.setattr(cn, "wait_clock", lambda _timeout: True)
    monkeypatch.setattr(cn, "move_base_goal", lambda spot, frame, stamp: spot)
    monkeypatch.setattr(rospy, "Publisher", lambda *a, **k: SimpleNamespace(publish=lambda msg: None))
    monkeypatch.setattr(rospy, "Subscriber", lambda *a, **k: None)
    monkeypatch.setattr(rospy, "get_name", lambda: "/auto_navigator")
    monkeypatch.setattr(rospy, "is_shutdown", lambda: True)
    monkeypatch.setattr(rospy.Time, "now", staticmethod(lambda: rospy.Time(100)))
    monkeypatch.setattr(rospy, "logwarn", lambda text, *a: warnings.append(text))
    monkeypatch.setattr(rospy, "logwarn_once", lambda text, *a: warnings.append(text), raising=False)
    return SimpleNamespace(warnings=warnings)


def node(stops=(A, B), dock=DOCK):
    return cn.CruiseNode(list(stops), 1, dock, dict(PARAMS))


def test_the_diagnostics_hardware_id_is_none_as_for_the_other_software_nodes(ros):
    """The cruise is software, no device: hardware_id "none" as move_base's and
    slam_gmapping's (it was the node's name)."""
    assert node().diagnostics.hardware_id == "none"


def test_the_diagnostic_task_reads_a_copy_never_the_cruise(ros):
    """NodeDiagnostics' timer thread called Cruise.status() while the loop changed the
    Cruise (current_stop() read index twice: an IndexError at a lap's end). The loop now
    stores the status after each step; the diagnostic task only reads that copy."""
    n = node()
    assert n._diagnose(0.0).message.startswith("waiting for the move_base action server")
    n.run()                                   # start: goal a sent (the loop then ends: is_shutdown)
    expected = n.cruise.status()

    def touched(*_a):
        raise AssertionError("the diagnostic task read the Cruise")
    n.cruise.status = n.cruise.current_stop = touched
    seen = []
    worker = threading.Thread(target=lambda: seen.append(n._diagnose(0.0)))
    worker.start()
    worker.join(5.0)
    assert seen == [expected] and dict(seen[0].values)["waypoint"] == "a"
