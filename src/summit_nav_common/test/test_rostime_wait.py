"""Waiting for ROS time without waking at every /clock message (summit_nav_common.ros.
rostime_wait), and the diagnostics thread that waits so (ros.diagnostics.NodeDiagnostics).

py-spy on slam_karto over the Intel bag at rate 4: the rospy.Timer that ticked the
diagnostics every 0.1 s of ROS time took about 15 % of the node's samples, nearly all of it
in rospy.sleep waking at each of rosbag play's 100 /clock messages per second.
"""
import pytest
import rospy

from summit_nav_common.ros import diagnostics, rostime_wait


class FakeWall:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def test_clock_rate_is_measured_once_enough_wall_time_passed_and_starts_over_when_time_goes_back():
    wall = FakeWall()
    rate = rostime_wait.ClockRate(wall)
    assert rate.read(0) is None
    wall.t += 0.1
    assert rate.read(400_000_000) is None                 # under RATE_WINDOW of wall time
    wall.t += 0.15
    assert rate.read(1_000_000_000) == pytest.approx(4.0)
    wall.t += 0.5
    assert rate.read(3_000_000_000) == pytest.approx(4.0)
    assert rate.read(1_000_000_000) is None                # a bag played again
    wall.t += 0.5
    assert rate.read(1_500_000_000) == pytest.approx(1.0)


@pytest.fixture
def sim_clock(monkeypatch):
    """ROS time from a variable, simulated time on, sleeps and condition waits recorded."""
    state = {"now": 10 * 10 ** 9, "slept": [], "cond_waits": 0}

    class Cond:
        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def wait(self, timeout):
            state["cond_waits"] += 1

    monkeypatch.setattr(rostime_wait, "now_ns", lambda: state["now"])
    monkeypatch.setattr(rostime_wait.rospy.rostime, "is_wallclock", lambda: False)
    monkeypatch.setattr(rostime_wait.rospy.rostime, "get_rostime_cond", lambda: Cond())
    monkeypatch.setattr(rostime_wait.time, "sleep", lambda s: state["slept"].append(s))
    return state


def test_a_long_wait_sleeps_in_wall_time_a_short_one_waits_on_the_clock(monkeypatch, sim_clock):
    monkeypatch.setattr(rostime_wait, "_RATE", type("R", (), {"read": lambda self, ns: 4.0})())
    rostime_wait.wait_until(sim_clock["now"] + 10 ** 9)            # 1 s of ROS time at 4x: 0.25 s
    assert sim_clock["slept"] == [pytest.approx(rostime_wait.SHARE * 0.25)] and sim_clock["cond_waits"] == 0
    rostime_wait.wait_until(sim_clock["now"] + 40 * 10 ** 6)       # 0.01 s of wall time
    assert len(sim_clock["slept"]) == 1 and sim_clock["cond_waits"] == 1
    rostime_wait.wait_until(sim_clock["now"] - 1)                  # already due
    assert len(sim_clock["slept"]) == 1 and sim_clock["cond_waits"] == 1
    # the rate unknown yet (the first readings): the clock condition
    monkeypatch.setattr(rostime_wait, "_RATE", type("R", (), {"read": lambda self, ns: None})())
    rostime_wait.wait_until(sim_clock["now"] + 10 ** 9)
    assert sim_clock["cond_waits"] == 2


class FakeUpdater:
    """diagnostic_updater.Updater's update(): publishes once its period is up."""

    def __init__(self, clock):
        self.clock, self.period, self.calls, self.published = clock, 1.0, 0, []
        self.last_time = rospy.Time(*divmod(clock["now"], 10 ** 9))

    def setHardwareID(self, _hwid):
        pass

    def update(self):
        self.calls += 1
        now = self.clock["now"]
        if now >= self.last_time.secs * 10 ** 9 + self.last_time.nsecs + int(self.period * 1e9):
            self.last_time = rospy.Time(*divmod(now, 10 ** 9))
            self.published.append(now / 1e9)


def test_diagnostics_update_once_per_period_of_ros_time(monkeypatch):
    """A bag clock at rate 4: 0.04 s of ROS time per /clock message. The updater is asked
    about once per period (the old 0.1 s timer asked ten times), publishes every 1 s, and
    after the clock is set back it publishes a period after it."""
    clock = {"now": 50 * 10 ** 9, "waits": 0}
    monkeypatch.setattr(diagnostics.threading, "Thread", lambda **kw: type("T", (), {"start": lambda self: None})())
    monkeypatch.setattr(diagnostics.diagnostic_updater, "Updater", lambda: FakeUpdater(clock))
    monkeypatch.setattr(diagnostics.rostime_wait, "now_ns", lambda: clock["now"])
    d = diagnostics.NodeDiagnostics()

    def tick(due):
        clock["waits"] += 1
        clock["now"] += 40 * 10 ** 6
        if clock["now"] >= 56 * 10 ** 9 and not clock.get("back"):
            clock["now"], clock["back"] = 20 * 10 ** 9, True        # a bag played again
        if clock["now"] >= 23 * 10 ** 9 and clock.get("back"):
            d.shutdown()
    monkeypatch.setattr(diagnostics.rostime_wait, "wait_until", tick)
    monkeypatch.setattr(diagnostics.rospy, "is_shutdown", lambda: False)
    d._run()
    u = d.updater
    assert u.published == pytest.approx([51.0, 52.0, 53.0, 54.0, 55.0, 21.0, 22.0])
    assert u.calls <= len(u.published) + 3
