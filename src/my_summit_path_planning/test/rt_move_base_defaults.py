#!/usr/bin/python3
"""rostest: move_base with no parameters at all reaches a goal.

Every parameter takes the real move_base's default (the node's private namespace holds
nothing, or only ~local_planner's base_local_planner); a goal 4 m away in the open hall,
inside the default 10 m x 10 m costmaps, must succeed within ~max_sim_time with the
robot within the default goal tolerances of the goal by ground truth (xy 0.10 m, yaw
0.05 rad, as dwa_local_planner's and base_local_planner's; plus amcl's margin) and zero
collisions.
"""
import math
import unittest

import rospy
import rostest

from summit_nav_common.geometry import wrap_angle
from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits

XY_TOLERANCE = 0.10     # [m] the local planners' default xy_goal_tolerance
YAW_TOLERANCE = 0.05    # [rad] their default yaw_goal_tolerance
AMCL_MARGIN = 0.10      # [m] ground truth vs amcl's estimate
AMCL_YAW_MARGIN = 0.05  # [rad]


class MoveBaseDefaults(unittest.TestCase):
    def test_goal_with_no_parameters(self):
        rospy.init_node("move_base_defaults_test")
        goal = (rospy.get_param("~goal_x"), rospy.get_param("~goal_y"), rospy.get_param("~goal_yaw"))
        max_sim = rospy.get_param("~max_sim_time", 90.0)
        allowed = {"base_local_planner"} if rospy.get_param("~local_planner", "") else set()
        truth = gt.Truth(gt.map_in_world())
        waits.wait_clock()
        c = mb.client()
        # move_base's own parameters (its dynamic_reconfigure servers write their namespaces)
        given = {k: v for k, v in rospy.get_param("/move_base", {}).items() if not isinstance(v, dict)}
        self.assertLessEqual(set(given), allowed, f"move_base was given parameters: {given}")
        truth.wait()
        waits.sleep_sim(2.0)  # amcl settles on its first scans
        c.send_goal(mb.make_goal(*goal))
        state, text = mb.wait_result(c, max_sim)
        waits.sleep_sim(0.5)
        end = truth.pose
        err_xy = math.hypot(end[0] - goal[0], end[1] - goal[1])
        err_yaw = abs(wrap_angle(end[2] - goal[2]))
        print(f"MOVE_BASE_DEFAULTS state={state} final_xy_error_m={err_xy:.3f} final_yaw_error_rad={err_yaw:.3f} "
              f"collisions={truth.collisions} text={text!r}")
        self.assertEqual(state, "SUCCEEDED", text)
        self.assertLessEqual(err_xy, XY_TOLERANCE + AMCL_MARGIN)
        self.assertLessEqual(err_yaw, YAW_TOLERANCE + AMCL_YAW_MARGIN)
        self.assertEqual(truth.collisions, 0, "the robot collided")


if __name__ == "__main__":
    rostest.rosrun("my_summit_path_planning", "move_base_defaults", MoveBaseDefaults)
