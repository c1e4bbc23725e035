#!/usr/bin/python3
"""rostest: the EKF in the loop on the tour beats the raw wheel odometry, by ground truth.

ekf.launch sim:=true tour:=true: the simulator's skid-steer odometry on /odom (its odom
tf off) and its IMU fused by ekf_localization_node. Every message of /odom,
/odometry/filtered and /base_pose_ground_truth is kept; when the tour driver says done,
each odometry is compared with the truth taken relative to the start pose (the odom
frame's origin; no alignment): the fused heading error at the end and the fused ATE must
be below the raw odometry's, no fused message may hold NaN, and the tf odom ->
base_footprint must be the EKF's (equal to its latest odometry/filtered).
"""
import math
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from nav_msgs.msg import Odometry
from std_msgs.msg import Bool

from my_summit_localization.odom_error import odom_error
from summit_nav_common.geometry import quaternion_to_yaw

WALL_LIMIT = 560.0   # [s] below the .test's time-limit


class Track:
    """(t, x, y, yaw) rows of an Odometry topic; counts messages with a non-finite field."""

    def __init__(self, topic):
        self.rows, self.not_finite, self.lock = [], 0, threading.Lock()
        self.last = None
        rospy.Subscriber(topic, Odometry, self.on_msg, queue_size=200)

    def on_msg(self, msg):
        p = msg.pose.pose
        values = [p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y, p.orientation.z,
                  p.orientation.w, *msg.pose.covariance, *msg.twist.covariance, msg.twist.twist.linear.x,
                  msg.twist.twist.angular.z]
        with self.lock:
            if not all(math.isfinite(v) for v in values):
                self.not_finite += 1
                return
            self.rows.append((msg.header.stamp.to_sec(), p.position.x, p.position.y, quaternion_to_yaw(p.orientation)))
            self.last = msg

    def array(self):
        with self.lock:
            return np.array(self.rows)


class EkfTour(unittest.TestCase):
    def test_fused_beats_raw_odometry(self):
        rospy.init_node("ekf_tour_test")
        buf = tf2_ros.Buffer(rospy.Duration(30.0))
        tf2_ros.TransformListener(buf)
        truth, raw, fused = Track("/base_pose_ground_truth"), Track("/odom"), Track("/odometry/filtered")
        done = []
        rospy.Subscriber("/tour_driver/done", Bool, lambda m: done.append(m.data), queue_size=1)
        t0 = time.monotonic()
        while not any(done):
            self.assertLess(time.monotonic() - t0, WALL_LIMIT, "the tour did not finish in time")
            time.sleep(0.2)
        time.sleep(1.0)   # the last messages
        self.assertEqual(fused.not_finite, 0, "odometry/filtered carried NaN or inf")
        self.assertGreater(len(fused.rows), 1000, "too few odometry/filtered messages")
        self.assertEqual(fused.last.header.frame_id, "odom")
        self.assertEqual(fused.last.child_frame_id, "base_footprint")
        tf = buf.lookup_transform("odom", "base_footprint", fused.last.header.stamp, rospy.Duration(2.0))
        self.assertAlmostEqual(tf.transform.translation.x, fused.last.pose.pose.position.x, places=6)
        gt = truth.array()
        e_raw, e_fused = odom_error(raw.array(), gt), odom_error(fused.array(), gt)
        rospy.loginfo(f"ekf tour: heading error at the end raw {math.degrees(e_raw.final_heading):.2f} deg, "
                      f"fused {math.degrees(e_fused.final_heading):.2f} deg; ATE raw {e_raw.ate:.3f} m, "
                      f"fused {e_fused.ate:.3f} m")
        self.assertLess(e_fused.final_heading, e_raw.final_heading,
                        f"fused heading error {math.degrees(e_fused.final_heading):.2f} deg not below the raw "
                        f"odometry's {math.degrees(e_raw.final_heading):.2f} deg")
        self.assertLess(e_fused.ate, e_raw.ate, f"fused ATE {e_fused.ate:.3f} m not below raw {e_raw.ate:.3f} m")


if __name__ == "__main__":
    rostest.rosrun("my_summit_localization", "ekf_tour", EkfTour)
