#!/usr/bin/python3
"""rostest: driven into a wall the robot stops at it, the collision count says 1; the
set_robot_pose / add_box / remove_box services, including their refusals."""
import math
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose2D, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import UInt32

from summit_xl_sim.srv import AddBox, RemoveBox, SetRobotPose

from summit_nav_common.testing.waits import Latest, sleep_sim, wait_clock

WALL_FACE_X = 0.10  # inner face of the west wall of the built-in world [m]
HALF_LENGTH = 0.36


class SimWalls(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sim_walls_test")
        cls.truth = Latest("/base_pose_ground_truth", Odometry)
        cls.coll = Latest("/collisions", UInt32)
        cls.scan = Latest("/hokuyo_base/scan", LaserScan)
        cls.cmd = rospy.Publisher("/summit_xl_control/cmd_vel", Twist, queue_size=1)
        for srv in ("set_robot_pose", "add_box", "remove_box"):
            rospy.wait_for_service("/summit_xl_sim/" + srv, timeout=30)
        cls.set_pose = rospy.ServiceProxy("/summit_xl_sim/set_robot_pose", SetRobotPose)
        cls.add_box = rospy.ServiceProxy("/summit_xl_sim/add_box", AddBox)
        cls.remove_box = rospy.ServiceProxy("/summit_xl_sim/remove_box", RemoveBox)
        wait_clock()
        cls.truth.wait()
        cls.coll.wait()
        cls.scan.wait()

    def drive(self, vx, seconds):
        t = Twist()
        t.linear.x = vx
        end = rospy.Time.now() + rospy.Duration.from_sec(seconds)
        rate = rospy.Rate(20)
        min_front = math.inf
        while rospy.Time.now() < end:
            self.cmd.publish(t)
            min_front = min(min_front, self.truth.msg.pose.pose.position.x - HALF_LENGTH)
            rate.sleep()
        # stop: else the last command, arriving late on a loaded machine, restarts the
        # watchdog after the next test's set_robot_pose and drives the robot on
        self.cmd.publish(Twist())
        return min_front

    def test_1_wall_stops_robot_and_counts_one_collision(self):
        self.assertEqual(self.coll.msg.data, 0)
        min_front = self.drive(1.0, 4.0)  # spawned at x = 2.0 facing west: 1.5 m to go
        sleep_sim(0.5)
        self.assertGreaterEqual(min_front, WALL_FACE_X - 1e-6)  # never inside the wall
        self.assertLess(self.truth.msg.pose.pose.position.x - HALF_LENGTH, WALL_FACE_X + 0.02)
        self.assertEqual(self.coll.msg.data, 1)

    def test_2_set_pose_and_refusals(self):
        ok = self.set_pose("", Pose2D(6.0, 7.0, 0.0))
        self.assertTrue(ok.success, ok.message)
        sleep_sim(0.2)
        self.assertAlmostEqual(self.truth.msg.pose.pose.position.x, 6.0, places=6)
        bad = self.set_pose("", Pose2D(12.0, 6.0, 0.0))  # in the wall between hall and fetch room
        self.assertFalse(bad.success)
        self.assertIn("wall", bad.message)
        off = self.set_pose("", Pose2D(100.0, 6.0, 0.0))
        self.assertFalse(off.success)
        self.assertIn("off the map", off.message)
        nobody = self.set_pose("robot_9", Pose2D(6.0, 7.0, 0.0))
        self.assertFalse(nobody.success)
        self.assertIn("robot_9", nobody.message)

    def test_3_box_seen_and_removed(self):
        self.set_pose("", Pose2D(6.0, 7.0, 0.0))
        sleep_sim(0.2)
        res = self.add_box("crate", Pose2D(8.0, 7.0, 0.0), 0.5, 0.5)
        self.assertTrue(res.success, res.message)
        scan = self.scan.wait_newer(rospy.Time.now().to_sec() + 0.05)
        self.assertAlmostEqual(scan.ranges[540], 8.0 - 0.25 - 6.25, delta=0.05)
        self.assertFalse(self.add_box("bad", Pose2D(8.0, 7.0, 0.0), -1.0, 0.5).success)
        self.assertFalse(self.add_box("onrobot", Pose2D(6.0, 7.0, 0.0), 0.3, 0.3).success)
        self.assertTrue(self.remove_box("crate").success)
        missing = self.remove_box("crate")
        self.assertFalse(missing.success)
        self.assertIn("no box named 'crate'", missing.message)
        scan = self.scan.wait_newer(rospy.Time.now().to_sec() + 0.05)
        self.assertGreater(scan.ranges[540], 3.0)


if __name__ == "__main__":
    rostest.rosrun("summit_xl_sim", "sim_walls", SimWalls)
