#!/usr/bin/python3
"""rostest: global localization converges while the tour drives.

amcl.launch with tour.launch; once amcl runs, /global_localization spreads the particles
over the whole map; the tour then drives. Every 0.1 s of sim time the pose amcl's tf
gives is compared with ground truth (map frame); it must come within ~pos_tol and
~yaw_tol_deg and stay there for ~hold s before ~max_drive m of driving.
"""
import math
import sys
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from std_srvs.srv import Empty

from summit_nav_common.geometry import quaternion_to_yaw as yaw_of
from summit_nav_common.testing.ground_truth import map_in_world, pose_error, truth_in_map
from summit_nav_common.testing.waits import Latest, sleep_sim, wait_clock, wait_for

SAMPLE = 0.1   # [s] sim


class AmclGlobal(unittest.TestCase):
    def test_global_localization_converges(self):
        rospy.init_node("amcl_global_test")
        pos_tol = rospy.get_param("~pos_tol", 0.2)
        yaw_tol = math.radians(rospy.get_param("~yaw_tol_deg", 10.0))
        hold = rospy.get_param("~hold", 2.0)
        max_drive = rospy.get_param("~max_drive", 25.0)
        buf = tf2_ros.Buffer(rospy.Duration(30.0))
        tf2_ros.TransformListener(buf)
        truth = Latest("/base_pose_ground_truth", Odometry)
        amcl_pose = Latest("/amcl_pose", PoseWithCovarianceStamped)
        # The widest cloud seen since the service call: the filter may collapse the cloud
        # in its very next update, before a poll of the latest message would see it.
        widest = {"armed": False, "spread": 0.0}

        def on_cloud(msg):
            if widest["armed"] and msg.poses:
                xs = [p.position.x for p in msg.poses]
                widest["spread"] = max(widest["spread"], max(xs) - min(xs))

        rospy.Subscriber("/particlecloud", PoseArray, on_cloud, queue_size=10)
        m_in_w = map_in_world()
        wait_clock()
        amcl_pose.wait(120.0)
        rospy.wait_for_service("/global_localization", 30.0)
        widest["armed"] = True
        rospy.ServiceProxy("/global_localization", Empty)()
        t0 = rospy.Time.now()
        wait_for(lambda: widest["spread"] > 10.0, "particle cloud spread over the map (> 10 m)", 60.0)
        last, driven, held = truth_in_map(truth.msg, m_in_w), 0.0, 0.0
        while True:
            sleep_sim(SAMPLE)
            gt = truth.msg
            now = truth_in_map(gt, m_in_w)
            driven += math.hypot(now[0] - last[0], now[1] - last[1])
            last = now
            try:
                t = buf.lookup_transform("map", "base_footprint", gt.header.stamp, rospy.Duration(0.5))
            except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                    tf2_ros.ExtrapolationException):
                continue
            est = (t.transform.translation.x, t.transform.translation.y, yaw_of(t.transform.rotation))
            e_pos, e_yaw = pose_error(est, now)
            held = held + SAMPLE if (e_pos < pos_tol and e_yaw < yaw_tol) else 0.0
            if held >= hold:
                break
            self.assertLess(driven, max_drive, f"not converged after {driven:.1f} m of driving "
                            f"(error {e_pos:.2f} m, {math.degrees(e_yaw):.1f} deg)")
        used = (rospy.Time.now() - t0).to_sec()
        rospy.loginfo(f"global localization converged after {driven:.1f} m, {used:.1f} s sim")
        print(f"GLOBAL converged driven_m={driven:.2f} sim_s={used:.1f}")


if __name__ == "__main__":
    rostest.rosrun("my_summit_localization", "amcl_global", AmclGlobal, sys.argv)
