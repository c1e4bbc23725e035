#!/usr/bin/python3
"""rostest: ekf_localization_node with bad input keeps filtering and says what was wrong.

The test drives /odom itself (wall time, 50 Hz, vx 0.5 m/s): messages with NaN, one
stamped before its predecessor and one 10 s in the future are dropped with a warning
naming /odom; /imu_never (configured, silent) is named once while the filter runs on
/odom; odometry/filtered never holds NaN and follows the odometry; set_pose moves the
estimate. Then bad parameters (a _config of 14 values, an unknown world_frame) each end
a fresh node with an error naming the parameter.
"""
import math
import os
import subprocess
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log

from my_summit_localization.srv import SetPose

RATE = 50.0   # [Hz] of the test's /odom
VX = 0.5      # [m/s]


class EkfBadInput(unittest.TestCase):
    def setUp(self):
        rospy.init_node("ekf_bad_input_test", anonymous=True)
        self.lock = threading.Lock()
        self.fused, self.not_finite, self.logs = [], 0, []
        rospy.Subscriber("/odometry/filtered", Odometry, self.on_fused, queue_size=100)
        # the node's own log messages (on /rosout, before rosout's aggregation)
        self.log_sub = rospy.Subscriber("/rosout", Log, self.on_log, queue_size=200)
        self.pub = rospy.Publisher("/odom", Odometry, queue_size=100)

    def on_fused(self, msg):
        p = msg.pose.pose.position
        with self.lock:
            if not all(math.isfinite(v) for v in (p.x, p.y, msg.twist.twist.linear.x, *msg.pose.covariance)):
                self.not_finite += 1
            else:
                self.fused.append((msg.header.stamp.to_sec(), p.x, p.y))

    def on_log(self, msg):
        with self.lock:
            self.logs.append((msg.name, msg.level, msg.msg))

    def odom(self, stamp, vx=VX):
        m = Odometry()
        m.header.stamp, m.header.frame_id, m.child_frame_id = stamp, "odom", "base_footprint"
        m.twist.twist.linear.x = vx
        m.pose.pose.orientation.w = 1.0
        m.twist.covariance = [1e-4 if i % 7 == 0 else 0.0 for i in range(36)]
        return m

    def drive(self, seconds, bad=None):
        """Publish /odom for `seconds` of wall time; bad(k, stamp) -> a message to send
        instead, or None."""
        rate = rospy.Rate(RATE)
        end = time.monotonic() + seconds
        k = 0
        while time.monotonic() < end:
            stamp = rospy.Time.now()
            msg = bad(k, stamp) if bad else None
            self.pub.publish(msg if msg is not None else self.odom(stamp))
            k += 1
            rate.sleep()

    def warnings(self, text):
        with self.lock:
            return [m for n, lvl, m in self.logs if n == "/ekf_se" and lvl >= Log.WARN and text in m]

    def test_bad_messages_and_parameters(self):
        deadline = time.monotonic() + 20.0
        while self.pub.get_num_connections() == 0 or self.log_sub.get_num_connections() == 0:
            self.assertLess(time.monotonic(), deadline, "ekf_se did not subscribe to /odom or log on /rosout")
            time.sleep(0.1)
        time.sleep(1.0)   # every connection to /rosout made

        def bad(k, stamp):
            if k == 20:
                return self.odom(stamp, vx=float("nan"))
            if k == 40:
                return self.odom(stamp - rospy.Duration(1.0))      # before its predecessor
            if k == 60:
                return self.odom(stamp + rospy.Duration(10.0))     # in the future
            return None
        self.drive(7.0, bad)
        with self.lock:
            fused = list(self.fused)
        self.assertEqual(self.not_finite, 0, "odometry/filtered held NaN")
        self.assertGreater(len(fused), 100)
        # it followed the odometry: 0.5 m/s over the span it covers
        (t0, x0, _), (t1, x1, _) = fused[len(fused) // 4], fused[-1]
        self.assertAlmostEqual((x1 - x0) / (t1 - t0), VX, delta=0.05)
        self.assertTrue(self.warnings("/odom: message dropped: vx is NaN"), "no warning about the NaN message")
        self.assertTrue(self.warnings("out of order"), "no warning about the message out of order")
        self.assertTrue(self.warnings("in the future"), "no warning about the message from the future")
        silent = self.warnings("no message on /imu_never")
        self.assertEqual(len(silent), 1, f"/imu_never named {len(silent)} times: {silent}")

        rospy.wait_for_service("/set_pose", timeout=10.0)
        req = PoseWithCovarianceStamped()
        req.header.frame_id = "odom"
        req.pose.pose.position.x, req.pose.pose.position.y = 10.0, -3.0
        req.pose.pose.orientation.w = 1.0
        req.pose.covariance = [0.01 if i % 7 == 0 else 0.0 for i in range(36)]
        rospy.ServiceProxy("/set_pose", SetPose)(req)
        t_set = rospy.Time.now().to_sec()
        self.drive(1.0)
        with self.lock:
            after = [r for r in self.fused if r[0] > t_set + 0.1]
        self.assertTrue(after, "no output after set_pose")
        self.assertAlmostEqual(after[-1][2], -3.0, delta=0.05)
        self.assertAlmostEqual(after[-1][1], 10.0, delta=0.8)

        for args, name in ((["_odom0:=/odom", "_odom0_config:=[true, true, true, true, true, true, true, true, true, "
                             "true, true, true, true, true]"], "odom0_config"),
                           (["_world_frame:=earth"], "world_frame")):
            proc = subprocess.run(["rosrun", "my_summit_localization", "ekf_localization_node", "__name:=ekf_bad"]
                                  + args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60,
                                  env=os.environ)
            self.assertNotEqual(proc.returncode, 0, f"{args}: the node did not end")
            self.assertIn(f"parameter '{name}'", proc.stdout, f"{args}: the error does not name {name}")
            rospy.delete_param("/ekf_bad") if rospy.has_param("/ekf_bad") else None


if __name__ == "__main__":
    rostest.rosrun("my_summit_localization", "ekf_bad_input", EkfBadInput)
