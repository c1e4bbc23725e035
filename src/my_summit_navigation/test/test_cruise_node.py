"""Unit tests of the cruise's ROS adapter (my_summit_navigation.cruise_node.CruiseNode)
without a ROS master: rospy's publishers, subscribers and clock, the move_base action
client and the diagnostics are replaced by fakes that record what the node does."""
import math
import threading
from types import SimpleNamespace

import pytest
import rospy
from sensor_msgs.msg import BatteryState

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


def battery_msg(percentage, present=True):
    return BatteryState(percentage=percentage, present=present)


@pytest.mark.parametrize("msg, problem", [
    (battery_msg(55.0), "outside 0..1"),
    (battery_msg(-0.1), "outside 0..1"),
    (battery_msg(math.nan), "NaN"),
    (battery_msg(0.5, present=False), "present is false"),
])
def test_an_unusable_battery_message_is_ignored_with_one_warning_naming_the_topic(ros, msg, problem):
    """A driver publishing 0-100 made 55 % read as 5500 % (never low); present false or a
    NaN level carry no level either."""
    n = node()
    n._on_battery(msg)
    n._on_battery(msg)
    assert n.events.empty()
    assert len(ros.warnings) == 1 and "/battery_state" in ros.warnings[0] and problem in ros.warnings[0]
    n._on_battery(battery_msg(0.5))
    assert n.events.get_nowait() == ("battery", 0.5, BatteryState.POWER_SUPPLY_STATUS_UNKNOWN)
    assert len(ros.warnings) == 1


def test_battery_messages_from_the_wait_for_move_base_are_handled_before_the_first_goal(ros):
    """A robot started with a low battery sent its first goal to waypoint 1, then
    canceled it for the dock: the battery messages queued while the node waited for
    move_base were handled only after start. It now drives to the dock first."""
    n = node()
    n.client.on_wait = lambda: n._on_battery(battery_msg(0.1))
    n.run()
    assert n.client.goals == [DOCK.spot] and n.client.canceled <= 1   # (the loop's end cancels)
    assert n.cruise.activity == cr.TO_DOCK and n.cruise.low_battery_events == 1


def test_other_events_queued_at_the_start_wait_for_the_loop(ros):
    n = node()
    n.client.on_wait = lambda: (n.events.put(("home",)), n._on_battery(battery_msg(0.8)))
    n.run()                                   # the loop does not run (is_shutdown)
    assert n.client.goals == [A.spot] and n.cruise.percentage == pytest.approx(0.8)
    assert list(n.events.queue) == [("home",)]


def test_the_power_supply_status_reaches_the_cruise(ros):
    """The charger's state comes from BatteryState.power_supply_status: the cruise
    re-sends the dock goal when it is not CHARGING within ~charge_start_timeout."""
    n = node()
    n.client.on_wait = lambda: n._on_battery(battery_msg(0.1))
    n.run()
    n._handle(("done", n.cruise._goal.goal_id, cr.SUCCEEDED, ""))     # docked
    msg = battery_msg(0.2)
    msg.power_supply_status = BatteryState.POWER_SUPPLY_STATUS_CHARGING
    n._on_battery(msg)
    n._handle(n.events.get_nowait())
    assert n.cruise.power_status == cr.POWER_CHARGING
