#!/usr/bin/python3
"""rostest: /save_spot at the three course spots, then `end`; spots.txt matches ground truth.

Launch: the simulator, amcl.launch (map_server + amcl), spot_recorder (~spots_file in a
scratch directory) and a second recorder whose spots file cannot be written (service
remapped to /bad_path/save_spot). For each spot of config/spots.yaml the robot is
teleported there (set_robot_pose), amcl is given a rough initialpose (0.15 m and 3 deg
off, as a user clicking rviz's 2D Pose Estimate) and refines it with
request_nomotion_update; then /save_spot is called with the label. `end` writes the file,
whose poses must match ground truth (in the map frame) within 0.1 m / 3 deg. A label used
twice is replaced and the answer says so; the unwritable path gives a clear error.
"""
import math
import os
import sys
import unittest

import rospkg
import rospy
import rostest
from geometry_msgs.msg import Pose2D, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from std_srvs.srv import Empty
from summit_xl_sim.srv import SetRobotPose

from my_summit_localization.spots import load_spots
from my_summit_localization.srv import MyServiceMessage

from summit_nav_common.geometry import compose
from summit_nav_common.testing.ground_truth import map_in_world, pose_error, spawn_in_world, truth_in_map
from summit_nav_common.testing.waits import Latest, sleep_sim, wait_clock

POS_TOL = 0.10              # [m] saved spot vs ground truth
YAW_TOL = math.radians(3)   # [rad]
NOMOTION_UPDATES = 15       # filter updates without motion after each initialpose
OFFSET = (0.15, -0.1, math.radians(3))  # initialpose error given to amcl [m, m, rad]


class SaveSpot(unittest.TestCase):
    def test_three_spots_then_end(self):
        rospy.init_node("save_spot_test")
        truth = Latest("/base_pose_ground_truth", Odometry)
        amcl_pose = Latest("/amcl_pose", PoseWithCovarianceStamped)
        init_pub = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=5, latch=True)
        for srv in ("/save_spot", "/bad_path/save_spot", "/request_nomotion_update",
                    "/summit_xl_sim/set_robot_pose"):
            rospy.wait_for_service(srv, 60.0)
        save = rospy.ServiceProxy("/save_spot", MyServiceMessage)
        save_bad = rospy.ServiceProxy("/bad_path/save_spot", MyServiceMessage)
        nomotion = rospy.ServiceProxy("/request_nomotion_update", Empty)
        teleport = rospy.ServiceProxy("/summit_xl_sim/set_robot_pose", SetRobotPose)
        spots_file = rospy.get_param("/spot_recorder/spots_file")
        bad_file = rospy.get_param("/spot_recorder_bad_path/spots_file")
        os.makedirs(os.path.dirname(spots_file), exist_ok=True)
        if os.path.exists(spots_file):
            os.unlink(spots_file)
        # the bad recorder's "directory" is a regular file: nothing can be written below it
        with open(os.path.dirname(bad_file), "w") as f:
            f.write("a file, not a directory\n")
        wait_clock()
        truth.wait()
        amcl_pose.wait(60.0)
        m_in_w = map_in_world()
        _, targets = load_spots(os.path.join(rospkg.RosPack().get_path("my_summit_localization"),
                                             "config", "spots.yaml"))
        nominal = spawn_in_world()
        saved_truth, saved_nominal = {}, {}
        for label in ("room", "turtle", "table", "room"):
            spot = targets[label]
            world = compose(m_in_w, (spot.x, spot.y, spot.yaw))
            r = teleport("", Pose2D(*world))
            self.assertTrue(r.success, r.message)
            sleep_sim(0.3)
            guess = compose((spot.x, spot.y, spot.yaw), OFFSET)
            msg = PoseWithCovarianceStamped()
            msg.header.frame_id, msg.header.stamp = "map", rospy.Time.now()
            msg.pose.pose.position.x, msg.pose.pose.position.y = guess[0], guess[1]
            msg.pose.pose.orientation.z = math.sin(guess[2] / 2)
            msg.pose.pose.orientation.w = math.cos(guess[2] / 2)
            c = [0.0] * 36
            c[0], c[7], c[35] = 0.04, 0.04, 0.01
            msg.pose.covariance = c
            init_pub.publish(msg)
            sleep_sim(0.3)
            for _ in range(NOMOTION_UPDATES):
                n = amcl_pose.count
                nomotion()
                amcl_pose.wait(30.0, after=n)
            r = save(label)
            saved_truth[label] = truth_in_map(truth.msg, m_in_w)
            saved_nominal[label] = truth_in_map(truth.msg, nominal)
            self.assertTrue(r.navigation_successfull, r.message)
            if label == "room" and len(saved_truth) == 3:
                self.assertIn("replaced", r.message)
            else:
                self.assertNotIn("replaced", r.message)
        # the bad recorder has poses too, but cannot write
        self.assertTrue(save_bad("room").navigation_successfull)
        r = save_bad("end")
        self.assertFalse(r.navigation_successfull)
        self.assertIn("not saved", r.message)
        self.assertIn(bad_file, r.message)
        # end: the file holds the three spots at the true poses
        r = save("end")
        self.assertTrue(r.navigation_successfull, r.message)
        frame, spots = load_spots(spots_file)
        self.assertEqual(frame, "map")
        self.assertEqual(list(spots), ["room", "turtle", "table"])
        for label, spot in spots.items():
            e_pos, e_yaw = pose_error((spot.x, spot.y, spot.yaw), saved_truth[label])
            e_nominal = pose_error((spot.x, spot.y, spot.yaw), saved_nominal[label])[0]
            rospy.loginfo(f"spot {label}: error {e_pos:.3f} m, {math.degrees(e_yaw):.2f} deg "
                          f"({e_nominal:.3f} m against the nominal spawn-shifted frame)")
            print(f"SPOT {label} error_m={e_pos:.4f} error_deg={math.degrees(e_yaw):.3f} "
                  f"nominal_frame_error_m={e_nominal:.4f}")
            self.assertLess(e_pos, POS_TOL, label)
            self.assertLess(e_yaw, YAW_TOL, label)
            self.assertLess(pose_error((spot.x, spot.y, spot.yaw), (targets[label].x, targets[label].y,
                                                                   targets[label].yaw))[0], 0.2)


if __name__ == "__main__":
    rostest.rosrun("my_summit_localization", "save_spot", SaveSpot, sys.argv)
