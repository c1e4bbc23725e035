#!/usr/bin/python3
"""rostest: a goal in another room reached through the move_base action.

From the spawn pose in the main hall to the fetch room's centre: the goal must succeed
within ~max_sim_time, the robot stand within the DWA goal tolerances of the goal by
ground truth (in the map frame; plus a margin for amcl's own error), with zero
collisions; on the way the action gives feedback and move_base publishes its global
plan, the local plan, the current goal and both costmaps (the costmaps matching the map's
geometry; the global one's changes on costmap_updates).
"""
import math
import sys
import unittest

import rospy
import rostest
from map_msgs.msg import OccupancyGridUpdate
from nav_msgs.msg import OccupancyGrid, Path
from geometry_msgs.msg import PolygonStamped, PoseStamped

from summit_nav_common.geometry import wrap_angle
from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits

AMCL_MARGIN = 0.10      # [m] ground truth vs amcl's estimate, on top of xy_goal_tolerance
AMCL_YAW_MARGIN = 0.05  # [rad]


class MoveBaseGoal(unittest.TestCase):
    def test_goal_in_another_room(self):
        rospy.init_node("move_base_goal_test")
        goal = (rospy.get_param("~goal_x"), rospy.get_param("~goal_y"), rospy.get_param("~goal_yaw"))
        max_sim = rospy.get_param("~max_sim_time", 90.0)
        xy_tol = rospy.get_param("/move_base/DWAPlannerROS/xy_goal_tolerance")
        yaw_tol = rospy.get_param("/move_base/DWAPlannerROS/yaw_goal_tolerance")
        m_in_w = gt.map_in_world()
        truth = gt.Truth(m_in_w)
        plan = waits.Latest("/move_base/NavfnROS/plan", Path)
        local_plan = waits.Latest("/move_base/DWAPlannerROS/local_plan", Path)
        gcost = waits.Latest("/move_base/global_costmap/costmap", OccupancyGrid)
        gupdates = waits.Latest("/move_base/global_costmap/costmap_updates", OccupancyGridUpdate)
        lcost = waits.Latest("/move_base/local_costmap/costmap", OccupancyGrid)
        foot = waits.Latest("/move_base/local_costmap/footprint", PolygonStamped)
        current_goal = waits.Latest("/move_base/current_goal", PoseStamped)
        the_map = waits.Latest("/map", OccupancyGrid)
        waits.wait_clock()
        c = mb.client()
        truth.wait()
        waits.sleep_sim(2.0)  # amcl settles on its first scans
        start = truth.pose
        feedback = []
        t0 = rospy.Time.now()
        c.send_goal(mb.make_goal(*goal), feedback_cb=feedback.append)
        state, text = mb.wait_result(c, max_sim)
        elapsed = (rospy.Time.now() - t0).to_sec()
        waits.sleep_sim(0.5)
        end = truth.pose
        err_xy = math.hypot(end[0] - goal[0], end[1] - goal[1])
        err_yaw = abs(wrap_angle(end[2] - goal[2]))
        straight = math.hypot(goal[0] - start[0], goal[1] - start[1])
        print(f"MOVE_BASE_GOAL state={state} time_to_goal_s={elapsed:.1f} straight_line_m={straight:.2f} "
              f"final_xy_error_m={err_xy:.3f} final_yaw_error_rad={err_yaw:.3f} collisions={truth.collisions} "
              f"text={text!r}")
        rospy.loginfo(f"move_base goal: {state} in {elapsed:.1f} s sim, final error {err_xy:.3f} m, "
                      f"{math.degrees(err_yaw):.1f} deg: {text}")
        self.assertEqual(state, "SUCCEEDED", text)
        self.assertIn("Goal reached", text)
        self.assertLessEqual(err_xy, xy_tol + AMCL_MARGIN)
        self.assertLessEqual(err_yaw, yaw_tol + AMCL_YAW_MARGIN)
        self.assertEqual(truth.collisions, 0, "the robot collided")
        # it really went to the other room: through the doorway at the hall's east wall
        self.assertTrue(any(x > 10.5 for _, x, _ in truth.track) and start[0] < 5.0)
        # feedback in the global frame, near the robot
        self.assertGreater(len(feedback), 10)
        fb = feedback[-1].base_position
        self.assertEqual(fb.header.frame_id, "map")
        self.assertLess(math.hypot(fb.pose.position.x - end[0], fb.pose.position.y - end[1]), 0.3)
        # plans and costmaps published under move_base's names
        self.assertGreater(plan.count, 0)
        p = plan.msg
        self.assertEqual(p.header.frame_id, "map")
        self.assertLess(math.hypot(p.poses[-1].pose.position.x - goal[0], p.poses[-1].pose.position.y - goal[1]),
                        0.05)
        cg = current_goal.wait()          # the goal as received, in the global frame
        self.assertEqual(cg.header.frame_id, "map")
        self.assertAlmostEqual(cg.pose.position.x, goal[0], places=6)
        self.assertAlmostEqual(cg.pose.position.y, goal[1], places=6)
        self.assertAlmostEqual(wrap_angle(2 * math.atan2(cg.pose.orientation.z, cg.pose.orientation.w) - goal[2]), 0.0,
                               places=6)
        self.assertGreater(local_plan.count, 0)
        self.assertEqual(local_plan.msg.header.frame_id, "odom")
        m = the_map.wait()
        g = gcost.wait()
        self.assertEqual(g.header.frame_id, "map")
        self.assertEqual((g.info.width, g.info.height), (m.info.width, m.info.height))
        self.assertAlmostEqual(g.info.origin.position.x, m.info.origin.position.x, places=6)
        self.assertIn(100, g.data)     # lethal
        self.assertIn(99, g.data)      # inscribed
        # the global grid is sent whole once; the laser's changes follow as windows of it
        u = gupdates.wait()
        self.assertEqual(u.header.frame_id, "map")
        self.assertTrue(0 <= u.x and u.x + u.width <= g.info.width and 0 <= u.y and u.y + u.height <= g.info.height)
        self.assertEqual(len(u.data), u.width * u.height)
        l = lcost.wait()
        self.assertEqual(l.header.frame_id, "odom")
        self.assertEqual((l.info.width, l.info.height), (140, 140))   # 7 m x 7 m at 0.05 m
        self.assertEqual(len(foot.wait().polygon.points), 4)


if __name__ == "__main__":
    rostest.rosrun("my_summit_path_planning", "move_base_goal", MoveBaseGoal, sys.argv)
