#!/usr/bin/python3
"""rostest: /get_coordinates preempted by a newer call; the stand-alone client drives.

Each test first puts the robot at a known pose of its own (put_robot: any goal
cancelled, the simulator's set_robot_pose, amcl re-initialised there with /initialpose
and a few updates without motion, the costmaps cleared), so none depends on where
another left the robot, nor on the order they run in. Judged by ground truth (in the
map frame of the committed map): the pose reached, and no collision.
- preemption: from the start (the map's origin) a call to the fetch room, then, while
  the robot drives, a newer call to a spot in the hall: the older answers false
  "preempted by a newer call", the newer "OK" with the robot within 0.3 m / 0.3 rad of
  its spot;
- the command-line client send_coordinates_action_client.py: x y yaw from that hall
  spot back to the start, past a pillar (exit 0, feedback printed, SUCCEEDED, within
  0.3 m / 0.3 rad).
"""
import math
import subprocess
import sys
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose2D, PoseWithCovarianceStamped
from std_srvs.srv import Empty
from summit_xl_sim.srv import SetRobotPose

from my_summit_localization.spots import load_spots
from my_summit_navigation.srv import MyServiceMessage

from summit_nav_common.geometry import compose, quaternion_to_yaw
from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits

SERVICE_WAIT = 120.0   # [s] wall: the stack may take a while to come up under load
XY_TOL, YAW_TOL = 0.3, 0.3   # [m], [rad] by ground truth
CLI_TIMEOUT = 300.0   # [s] wall bound of one command-line client run
START = (0.0, 0.0, 0.0)   # [m, m, rad] map frame: where main.launch starts the robot
INIT_STD = (0.05, 0.05, 0.03)   # [m, m, rad] std of the /initialpose given to amcl
NOMOTION_UPDATES = 5    # amcl updates without motion after an /initialpose
AMCL_TOL = 0.1          # [m] amcl within this of the truth before a test drives


def run_client(*args):
    """(exit code, output) of send_coordinates_action_client.py with args."""
    p = subprocess.run(["rosrun", "my_summit_navigation", "send_coordinates_action_client.py", *args],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=CLI_TIMEOUT)
    print(f"CLI {' '.join(args)} -> exit {p.returncode}:\n{p.stdout}", flush=True)
    return p.returncode, p.stdout


class GetCoordinatesDrives(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("get_coordinates_drives_test")
        _, cls.hall = load_spots(rospy.get_param("~hall_file"))
        cls.truth = gt.Truth(gt.map_in_world())
        cls.amcl_pose = waits.Latest("/amcl_pose", PoseWithCovarianceStamped)
        cls.init_pub = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=5)
        waits.wait_clock()
        for name in ("/hall/get_coordinates", "/summit_xl_sim/set_robot_pose", "/request_nomotion_update",
                     "/move_base/clear_costmaps"):
            rospy.wait_for_service(name, SERVICE_WAIT)
        cls.hall_srv = rospy.ServiceProxy("/hall/get_coordinates", MyServiceMessage)
        cls.teleport = rospy.ServiceProxy("/summit_xl_sim/set_robot_pose", SetRobotPose)
        cls.nomotion = rospy.ServiceProxy("/request_nomotion_update", Empty)
        cls.clear_costmaps = rospy.ServiceProxy("/move_base/clear_costmaps", Empty)
        cls.move_base = mb.client()
        cls.truth.wait()
        cls.amcl_pose.wait(SERVICE_WAIT)

    def put_robot(self, pose):
        """Stop whatever drives the robot and put it at pose (x, y, yaw) [m, m, rad] in the
        map frame: ground truth, amcl and the costmaps."""
        self.move_base.cancel_all_goals()
        waits.sleep_sim(1.0)                     # move_base stops; the base brakes
        r = self.teleport("", Pose2D(*compose(self.truth.m_in_w, pose)))
        self.assertTrue(r.success, r.message)
        waits.sleep_sim(0.3)
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id, msg.header.stamp = "map", rospy.Time.now()
        msg.pose.pose.position.x, msg.pose.pose.position.y = pose[0], pose[1]
        msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(pose[2] / 2), math.cos(pose[2] / 2)
        cov = [0.0] * 36
        cov[0], cov[7], cov[35] = INIT_STD[0] ** 2, INIT_STD[1] ** 2, INIT_STD[2] ** 2
        msg.pose.covariance = cov
        n = self.amcl_pose.count
        self.init_pub.publish(msg)
        self.amcl_pose.wait(30.0, after=n)
        for _ in range(NOMOTION_UPDATES):
            n = self.amcl_pose.count
            self.nomotion()
            self.amcl_pose.wait(30.0, after=n)
        self.clear_costmaps()                 # the marks seen from where the robot was
        waits.sleep_sim(1.0)                     # the local costmap fills again from the laser
        p = self.amcl_pose.msg.pose.pose
        est = (p.position.x, p.position.y, quaternion_to_yaw(p.orientation))
        err = gt.pose_error(est, self.truth.pose)
        self.assertLess(gt.pose_error(self.truth.pose, pose)[0], 0.02, "set_robot_pose did not place the robot")
        self.assertLess(err[0], AMCL_TOL, f"amcl {err[0]:.3f} m off the truth after /initialpose")
        self.collisions = self.truth.collisions

    def assert_at(self, pose, what):
        """Ground truth within XY_TOL / YAW_TOL of pose, and no collision since put_robot."""
        waits.sleep_sim(0.5)
        err_xy, err_yaw = gt.pose_error(self.truth.pose, pose)
        print(f"{what}: final error {err_xy:.3f} m {err_yaw:.3f} rad", flush=True)
        self.assertLessEqual(err_xy, XY_TOL, what)
        self.assertLessEqual(err_yaw, YAW_TOL, what)
        self.assertEqual(self.truth.collisions, self.collisions, "the robot collided")

    def test_preemption_by_a_newer_call(self):
        self.put_robot(START)
        answers = {}

        def older():
            answers["far"] = self.hall_srv("far")
            answers["far_at"] = rospy.Time.now()

        thread = threading.Thread(target=older, daemon=True)
        thread.start()
        here = self.truth.pose
        waits.wait_for(lambda: gt.pose_error(self.truth.pose, here)[0] > 1.0, "the robot driving toward 'far'", 200.0)
        self.assertNotIn("far", answers, "the first call should still be running")
        t0 = rospy.Time.now()
        r = self.hall_srv("near")
        took = (rospy.Time.now() - t0).to_sec()
        thread.join(30.0)
        self.assertIn("far", answers, "the older call did not answer")
        far = answers["far"]
        print(f"PREEMPT older: {far.message!r} after {(answers['far_at'] - t0).to_sec():.2f} s sim; newer: "
              f"{r.message!r} after {took:.1f} s sim", flush=True)
        self.assertFalse(far.navigation_successfull)
        self.assertEqual(far.message, "preempted by a newer call (label 'near')")
        self.assertLess((answers["far_at"] - t0).to_sec(), 2.0, "the older call should answer at once")
        self.assertTrue(r.navigation_successfull, r.message)
        self.assertEqual(r.message, "OK")
        near = self.hall["near"]
        self.assert_at((near.x, near.y, near.yaw), "PREEMPT newer 'near'")

    def test_cli_drives_to_x_y_yaw(self):
        near = self.hall["near"]
        self.put_robot((near.x, near.y, near.yaw))     # where the preemption test ends
        rc, out = run_client(*(f"{v:g}" for v in START))
        self.assertEqual(rc, 0, out)
        self.assertIn("feedback: robot at", out)
        self.assertIn("result: SUCCEEDED", out)
        self.assert_at(START, "CLI x y yaw")


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "get_coordinates_drives", GetCoordinatesDrives, sys.argv)
