#!/usr/bin/python3
"""rostest: /imu/data (rate, frame, the static tf to imu_link, gravity, covariances, a
turn's heading against the truth), the skid odometry's covariances, and no tf
odom -> base_footprint with publish_odom_tf false while /odom keeps flowing."""
import math
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu

from summit_nav_common.geometry import quaternion_to_yaw as yaw_of
from summit_nav_common.geometry import wrap_angle
from summit_nav_common.testing.waits import Latest, sleep_sim, wait_clock


class SimImu(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sim_imu_test")
        cls.imu = Latest("/imu/data", Imu)
        cls.odom = Latest("/odom", Odometry)
        cls.truth = Latest("/base_pose_ground_truth", Odometry)
        cls.cmd = rospy.Publisher("/summit_xl_control/cmd_vel", Twist, queue_size=1)
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)
        wait_clock()
        cls.imu.wait()
        cls.truth.wait()

    def test_1_rate_frame_static_tf_and_gravity_at_rest(self):
        msg = self.imu.wait()
        self.assertEqual(msg.header.frame_id, "imu_link")
        t0 = rospy.Time.now().to_sec() + 0.2
        sleep_sim(3.0)
        self.assertAlmostEqual(self.imu.rate_between(t0, t0 + 2.0), 100.0, delta=1.0)
        t = self.tf_buffer.lookup_transform("base_footprint", "imu_link", rospy.Time(0), rospy.Duration(5.0))
        self.assertAlmostEqual(t.transform.translation.x, 0.10, places=6)
        self.assertAlmostEqual(t.transform.translation.y, 0.05, places=6)
        self.assertAlmostEqual(t.transform.translation.z, 0.21, places=6)
        msg = self.imu.msg
        # at rest: +g on z within the noise (1.75 mg per sample, 5 sigma), no rotation
        self.assertAlmostEqual(msg.linear_acceleration.z, 9.80665, delta=0.1)
        self.assertLess(abs(msg.linear_acceleration.x), 0.1)
        self.assertLess(abs(msg.angular_velocity.z), 0.02)
        for cov in (msg.angular_velocity_covariance, msg.linear_acceleration_covariance,
                    msg.orientation_covariance):
            self.assertTrue(all(cov[i] > 0.0 for i in (0, 4, 8)), cov)

    def test_2_no_odom_tf_but_odom_flows(self):
        sleep_sim(1.0)
        self.assertFalse(self.tf_buffer.can_transform("odom", "base_footprint", rospy.Time(0),
                                                      rospy.Duration(2.0)),
                         "publish_odom_tf false, yet tf odom -> base_footprint exists")
        msg = self.odom.wait()
        self.assertEqual((msg.header.frame_id, msg.child_frame_id), ("odom", "base_footprint"))
        t0 = rospy.Time.now().to_sec()
        sleep_sim(2.0)
        self.assertGreater(self.odom.rate_between(t0, t0 + 1.5), 45.0)

    def test_3_turn_heading_imu_against_truth_and_skid_odometry(self):
        yaw_truth0 = yaw_of(self.truth.msg.pose.pose.orientation)
        yaw_imu0 = yaw_of(self.imu.msg.orientation)
        yaw_odom0 = yaw_of(self.odom.msg.pose.pose.orientation)
        t = Twist()
        t.angular.z = 1.5
        end = rospy.Time.now() + rospy.Duration.from_sec(1.4)  # < pi in all: no wrap
        rate = rospy.Rate(20)
        wz_odom, wz_true = [], []
        while rospy.Time.now() < end:
            self.cmd.publish(t)
            if abs(self.truth.msg.twist.twist.angular.z - 1.5) < 1e-6:
                wz_odom.append(self.odom.msg.twist.twist.angular.z)
                wz_true.append(1.5)
            rate.sleep()
        sleep_sim(1.0)  # watchdog and braking: at rest again
        turned_truth = wrap_angle(yaw_of(self.truth.msg.pose.pose.orientation) - yaw_truth0)
        turned_imu = wrap_angle(yaw_of(self.imu.msg.orientation) - yaw_imu0)
        turned_odom = wrap_angle(yaw_of(self.odom.msg.pose.pose.orientation) - yaw_odom0)
        self.assertGreater(abs(turned_truth), 1.5)
        # BMI088: 0.14 deg/s noise per sample at 100 Hz integrates to well under 0.01 rad
        self.assertAlmostEqual(turned_imu, turned_truth, delta=0.01)
        # skid: the wheels overestimate a 1.5 rad/s turn by 2.5 % + 2 % x 1.5 = 5.5 % (s(t) +-1 %)
        ratio = turned_odom / turned_truth
        self.assertGreater(ratio, 1.02)
        self.assertLess(ratio, 1.10)
        self.assertTrue(wz_odom, "never saw the turn at full rate")
        self.assertAlmostEqual(sum(wz_odom) / len(wz_odom) / 1.5, ratio, delta=0.03)
        cov = self.odom.msg.pose.covariance
        self.assertGreater(cov[35], 0.0)   # yaw variance grew with the turn


if __name__ == "__main__":
    rostest.rosrun("summit_xl_sim", "sim_imu", SimImu)
