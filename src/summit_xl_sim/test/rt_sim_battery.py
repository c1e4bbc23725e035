#!/usr/bin/python3
"""rostest on the race track: the robot spawned docked; /battery_state at >= 1 Hz;
~set_battery sets 0.5 and refuses out-of-range values with a message; driving away drains,
standing at the dock charges (CHARGING); /diagnostics carries the scan, odometry,
real-time factor and battery checks (the scan's "no subscriber": none here), the battery
WARN at 15 % and ERROR at 3 %."""
import math
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState

from summit_xl_sim.srv import SetBattery

from summit_nav_common.testing.waits import Latest, sleep_sim, wait_clock

DOCK = (0.0, -4.0)  # race_track_waypoints.yaml's dock [m]
CHECKS = ("summit_xl_sim: Laser scan rate", "summit_xl_sim: Odometry rate", "summit_xl_sim: Battery",
          "summit_xl_sim: Real-time factor")


class SimBattery(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sim_battery_test")
        cls.truth = Latest("/base_pose_ground_truth", Odometry)
        cls.battery = Latest("/battery_state", BatteryState)
        cls.diag = {}
        cls.diag_sub = rospy.Subscriber("/diagnostics", DiagnosticArray, cls._on_diag, queue_size=None)
        cls.cmd = rospy.Publisher("/summit_xl_control/cmd_vel", Twist, queue_size=1)
        rospy.wait_for_service("/summit_xl_sim/set_battery", timeout=30)
        cls.set_battery = rospy.ServiceProxy("/summit_xl_sim/set_battery", SetBattery)
        wait_clock()
        cls.truth.wait()
        cls.battery.wait()

    @classmethod
    def _on_diag(cls, msg):
        for s in msg.status:
            cls.diag[s.name] = (msg.header.stamp.to_sec(), s)

    def diag_after(self, name, t, timeout_wall=30.0):
        """The status `name` from a /diagnostics message stamped after t [s]."""
        deadline = time.monotonic() + timeout_wall
        while time.monotonic() < deadline:
            got = self.diag.get(name)
            if got and got[0] > t:
                return got[1]
            time.sleep(0.02)
        raise AssertionError(f"no '{name}' on /diagnostics stamped after {t:.1f} s (have {sorted(self.diag)})")

    def drive(self, vx, seconds):
        t = Twist()
        t.linear.x = vx
        end = rospy.Time.now() + rospy.Duration.from_sec(seconds)
        rate = rospy.Rate(20)
        while rospy.Time.now() < end:
            self.cmd.publish(t)
            rate.sleep()

    def test_1_spawned_docked_and_battery_state_at_1_hz(self):
        p = self.truth.msg.pose.pose.position
        self.assertLess(math.hypot(p.x - DOCK[0], p.y - DOCK[1]), 1e-6)
        t0 = rospy.Time.now().to_sec()
        sleep_sim(4.0)
        self.assertGreaterEqual(self.battery.rate_between(t0, t0 + 4.0), 1.0)
        msg = self.battery.msg
        self.assertTrue(msg.present)
        self.assertGreater(msg.voltage, 20.0)
        self.assertIn(msg.power_supply_status, (BatteryState.POWER_SUPPLY_STATUS_FULL,
                                                BatteryState.POWER_SUPPLY_STATUS_CHARGING))

    def test_2_set_battery_and_its_refusals(self):
        ok = self.set_battery(0.5, "")
        self.assertTrue(ok.success, ok.message)
        t = rospy.Time.now().to_sec()
        msg = self.battery.wait_newer(t)
        self.assertAlmostEqual(msg.percentage, 0.5, delta=0.02)  # charging since: at most 1 s
        for bad in (1.5, -0.1, float("nan")):
            res = self.set_battery(bad, "")
            self.assertFalse(res.success)
            self.assertIn("percentage must be in 0..1", res.message)
        nobody = self.set_battery(0.5, "robot_9")
        self.assertFalse(nobody.success)
        self.assertIn("robot_9", nobody.message)

    def test_3_driving_drains_and_the_dock_charges(self):
        self.set_battery(0.6, "")
        self.drive(0.4, 2.0)  # along the pit lane, away from the dock
        t = rospy.Time.now().to_sec()
        away = self.battery.wait_newer(t)
        self.assertEqual(away.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        self.assertLess(away.current, 0.0)
        p = self.truth.msg.pose.pose.position
        self.assertGreater(math.hypot(p.x - DOCK[0], p.y - DOCK[1]), 0.5)
        sleep_sim(1.0)
        later = self.battery.wait_newer(rospy.Time.now().to_sec())
        self.assertLess(later.percentage, away.percentage)  # drains at rest too
        self.drive(-0.4, 2.0)  # back to the dock, then stand still
        sleep_sim(1.0)
        p = self.truth.msg.pose.pose.position
        self.assertLess(math.hypot(p.x - DOCK[0], p.y - DOCK[1]), 0.3)
        first = self.battery.wait_newer(rospy.Time.now().to_sec())
        sleep_sim(2.0)
        second = self.battery.wait_newer(rospy.Time.now().to_sec())
        self.assertEqual(second.power_supply_status, BatteryState.POWER_SUPPLY_STATUS_CHARGING)
        self.assertGreater(second.percentage, first.percentage)
        self.assertGreater(second.current, 0.0)

    def test_4_diagnostics_checks_and_battery_levels(self):
        t = rospy.Time.now().to_sec()
        for name in CHECKS:
            s = self.diag_after(name, t)
            self.assertEqual(s.hardware_id, "summit_xl")
        scan = self.diag_after(CHECKS[0], t)   # nobody here subscribes to the scan: none cast
        self.assertEqual((scan.level, scan.message), (DiagnosticStatus.OK, "no subscriber: scans not cast"))
        self.assertEqual(self.diag_after(CHECKS[1], t).level, DiagnosticStatus.OK)
        # the real-time factor's level depends on the machine's load: its values only
        pace = {v.key: v.value for v in self.diag_after(CHECKS[3], t).values}
        self.assertEqual(pace["asked speed"], "4")
        self.assertGreater(float(pace["real-time factor"]), 0.0)
        self.drive(0.4, 1.5)  # off the dock: the level stays where it is set
        for pct, level, words in ((0.15, DiagnosticStatus.WARN, "15 % discharging"),
                                  (0.03, DiagnosticStatus.ERROR, "3 % discharging"),
                                  (0.8, DiagnosticStatus.OK, "80 % discharging")):
            self.assertTrue(self.set_battery(pct, "").success)
            s = self.diag_after(CHECKS[2], rospy.Time.now().to_sec())
            self.assertEqual(s.level, level, s.message)
            self.assertIn(words, s.message)
            values = {v.key: v.value for v in s.values}
            self.assertAlmostEqual(float(values["Percentage"]), pct, delta=0.005)
            self.assertEqual(values["Status"], "discharging")


if __name__ == "__main__":
    rostest.rosrun("summit_xl_sim", "sim_battery", SimBattery)
