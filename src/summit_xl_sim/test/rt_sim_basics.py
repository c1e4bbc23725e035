#!/usr/bin/python3
"""rostest: topics, rates (sim time), tf chain, motion as commanded, watchdog, NaN twist."""
import math
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan

from summit_nav_common.geometry import quaternion_to_yaw as yaw_of
from summit_nav_common.testing.waits import Latest, sleep_sim, wait_clock


class SimBasics(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sim_basics_test")
        cls.scan = Latest("/hokuyo_base/scan", LaserScan)
        cls.odom = Latest("/odom", Odometry)
        cls.truth = Latest("/base_pose_ground_truth", Odometry)
        cls.cmd = rospy.Publisher("/summit_xl_control/cmd_vel", Twist, queue_size=1)
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)
        wait_clock()
        cls.scan.wait()
        cls.truth.wait()

    def drive(self, vx, wz, seconds):
        """Publish a command at 20 Hz of sim time for `seconds`; returns the last ground
        truth received while the commands still flowed."""
        t = Twist()
        t.linear.x, t.angular.z = vx, wz
        end = rospy.Time.now() + rospy.Duration.from_sec(seconds)
        rate = rospy.Rate(20)
        moving = None
        while rospy.Time.now() < end:
            self.cmd.publish(t)
            moving = self.truth.msg
            rate.sleep()
        return moving

    def test_1_scan_shape_and_rate(self):
        msg = self.scan.wait()
        self.assertEqual(len(msg.ranges), 1081)
        self.assertEqual(msg.header.frame_id, "hokuyo_base_link")
        self.assertAlmostEqual(msg.angle_min, -2.356, places=3)
        self.assertAlmostEqual(msg.angle_max, 2.356, places=3)
        self.assertAlmostEqual(msg.range_max, 30.0)
        self.assertAlmostEqual(msg.range_min, 0.10)
        t0 = rospy.Time.now().to_sec() + 0.5
        sleep_sim(5.0)
        # 4 s of stamps, well before the last message we may have received
        self.assertAlmostEqual(self.scan.rate_between(t0, t0 + 4.0), 40.0, delta=0.5)
        self.assertAlmostEqual(self.odom.rate_between(t0, t0 + 4.0), 50.0, delta=0.5)

    def test_2_tf_chain(self):
        for parent, child in [("odom", "base_footprint"), ("base_footprint", "base_link"),
                              ("base_link", "hokuyo_base_link")]:
            self.tf_buffer.lookup_transform(parent, child, rospy.Time(0), rospy.Duration(5.0))
        t = self.tf_buffer.lookup_transform("base_footprint", "hokuyo_base_link", rospy.Time(0))
        self.assertAlmostEqual(t.transform.translation.x, 0.25, places=6)
        self.assertAlmostEqual(t.transform.translation.z, 0.43, places=6)
        self.assertEqual(self.odom.msg.header.frame_id, "odom")
        self.assertEqual(self.odom.msg.child_frame_id, "base_footprint")

    def test_3_moves_as_commanded_then_watchdog_stops(self):
        p0 = self.truth.msg.pose.pose
        # Read while the commands still flow: a fixed wait after the last one can outlast
        # the 0.25 s watchdog when this test node is starved (CI: 0.0125 m/s, braking).
        moving = self.drive(0.5, 0.0, 2.0)
        self.assertAlmostEqual(moving.twist.twist.linear.x, 0.5, delta=0.05)  # running
        sleep_sim(0.8)  # > 0.25 s watchdog + 0.2 s of braking
        stopped = self.truth.msg
        self.assertEqual(stopped.twist.twist.linear.x, 0.0)
        dx = stopped.pose.pose.position.x - p0.position.x
        # ~2 s at 0.5 m/s (+ the command's last period and the braking, - the ramp)
        self.assertGreater(dx, 0.9)
        self.assertLess(dx, 1.25)
        self.assertAlmostEqual(stopped.pose.pose.position.y, p0.position.y, delta=0.01)
        sleep_sim(0.5)
        self.assertAlmostEqual(self.truth.msg.pose.pose.position.x, stopped.pose.pose.position.x, places=9)

    def test_4_turns_as_commanded(self):
        yaw0 = yaw_of(self.truth.msg.pose.pose.orientation)
        self.drive(0.0, 1.0, 1.5)
        sleep_sim(1.0)
        turned = math.remainder(yaw_of(self.truth.msg.pose.pose.orientation) - yaw0, 2 * math.pi)
        self.assertGreater(turned, 1.3)
        self.assertLess(turned, 2.0)

    def test_5_nan_twist_ignored(self):
        p0 = self.truth.msg.pose.pose.position
        t = Twist()
        t.linear.x = float("nan")
        for _ in range(10):
            self.cmd.publish(t)
            sleep_sim(0.05)
        sleep_sim(0.3)
        p1 = self.truth.msg.pose.pose.position
        self.assertEqual((p0.x, p0.y), (p1.x, p1.y))


if __name__ == "__main__":
    rostest.rosrun("summit_xl_sim", "sim_basics", SimBasics)
