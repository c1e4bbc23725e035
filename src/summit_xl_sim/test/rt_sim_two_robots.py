#!/usr/bin/python3
"""rostest: two robots, each in its namespace with prefixed frames, see each other."""
import unittest

import rospy
import rostest
import tf2_ros
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan

from summit_nav_common.testing.waits import Latest, wait_clock


class TwoRobots(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sim_two_robots_test")
        cls.scans = {r: Latest(f"/{r}/hokuyo_base/scan", LaserScan) for r in ("robot_0", "robot_1")}
        cls.odoms = {r: Latest(f"/{r}/odom", Odometry) for r in ("robot_0", "robot_1")}
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)
        wait_clock()
        for r in ("robot_0", "robot_1"):
            cls.scans[r].wait()
            cls.odoms[r].wait()

    def test_namespaces_and_frames(self):
        for r in ("robot_0", "robot_1"):
            self.assertEqual(self.scans[r].msg.header.frame_id, f"{r}/hokuyo_base_link")
            self.assertEqual(self.odoms[r].msg.header.frame_id, f"{r}/odom")
            self.assertEqual(self.odoms[r].msg.child_frame_id, f"{r}/base_footprint")
            self.tf_buffer.lookup_transform(f"{r}/odom", f"{r}/hokuyo_base_link", rospy.Time(0),
                                            rospy.Duration(5.0))

    def test_robots_see_each_other(self):
        # robot_0 at (5, 7) facing +x, robot_1 at (8, 7) facing -x; lasers 0.25 m forward.
        r0 = self.scans["robot_0"].msg.ranges[540]
        r1 = self.scans["robot_1"].msg.ranges[540]
        self.assertAlmostEqual(r0, (8.0 - 0.36) - (5.0 + 0.25), delta=0.05)
        self.assertAlmostEqual(r1, (8.0 - 0.25) - (5.0 + 0.36), delta=0.05)


if __name__ == "__main__":
    rostest.rosrun("summit_xl_sim", "sim_two_robots", TwoRobots)
