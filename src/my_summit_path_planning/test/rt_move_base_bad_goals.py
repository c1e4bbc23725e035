#!/usr/bin/python3
"""rostest: move_base with no map yet, then bad goals, then its two services.

1. No map yet: a goal waits (stays active) and move_base says so on /rosout; once the
   map comes the goal runs (feedback), and a cancel ends it preempted.
2. Bad goals end aborted at once, before move_base pursues them (not one feedback
   message, which every control cycle publishes), the result text naming the reason: in a wall, off the map, in unknown space, NaN, a non-unit
   quaternion, a tilted quaternion, a frame that cannot be transformed.
3. ~make_plan: a plan to the fetch room (ends at the goal), a goal near a wall moved
   to free space within default_tolerance, a goal given in base_footprint transformed
   into the map frame (from where the robot stands), an empty plan for a goal in a wall; ~clear_costmaps answers.
"""
import math
import sys
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseStamped, TransformStamped
from nav_msgs.msg import OccupancyGrid
from nav_msgs.srv import GetPlan, GetPlanRequest
from std_srvs.srv import Empty
from rospy.numpy_msg import numpy_msg

from summit_nav_common.geometry import compose, quaternion_to_yaw
from summit_nav_common.ros.map_msgs import grid_to_msg
from summit_nav_common.map_io import load_map

from summit_nav_common.testing import move_base_client as mb, waits

ROOM = (14.0, -3.5)   # [m] the fetch room's centre in the map frame
WALL_NEAR = (10.0, -1.0)   # [m] near the hall / fetch room wall (world x = 12)


def robot_in_map(tf_buf):
    """(x, y, yaw) of base_footprint in the map frame, from the latest tf."""
    t = tf_buf.lookup_transform("map", "base_footprint", rospy.Time(0), rospy.Duration(5.0)).transform
    return t.translation.x, t.translation.y, quaternion_to_yaw(t.rotation)


def occupied_cell_near(grid, x, y):
    """Centre (x, y) [m] of the occupied map cell nearest (x, y)."""
    rows, cols = np.nonzero(grid.data == 100)
    cx = grid.origin[0] + (cols + 0.5) * grid.resolution
    cy = grid.origin[1] + (rows + 0.5) * grid.resolution
    k = int(np.argmin(np.hypot(cx - x, cy - y)))
    return float(cx[k]), float(cy[k])


class MoveBaseBadGoals(unittest.TestCase):
    def test_no_map_bad_goals_services(self):
        rospy.init_node("move_base_bad_goals_test")
        rosout = waits.RosoutWatcher()
        waits.wait_clock()
        static = tf2_ros.StaticTransformBroadcaster()
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id, t.child_frame_id = "map", "odom"
        t.transform.rotation.w = 1.0
        static.sendTransform(t)
        tf_buf = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(tf_buf)
        c = mb.client()

        # 1. no map yet: the goal waits and move_base says so
        fb = []
        c.send_goal(mb.make_goal(*ROOM), feedback_cb=fb.append)
        rosout.wait("move_base", "waiting for the map")
        waits.sleep_sim(1.0)
        self.assertEqual(mb.state_name(c), "ACTIVE")
        grid = load_map(rospy.get_param("~map_file"))
        map_pub = rospy.Publisher("/map", numpy_msg(OccupancyGrid), queue_size=1, latch=True)
        map_pub.publish(grid_to_msg(grid, "map", rospy.Time.now(), numpy_msg(OccupancyGrid)))
        self.assertEqual(len(fb), 0)
        waits.wait_for(lambda: len(fb) > 5, "feedback once the map is there", 60.0)
        c.cancel_goal()
        state, text = mb.wait_result(c, 10.0)
        self.assertEqual(state, "PREEMPTED", text)
        self.assertIn("canceled", text)

        # 2. bad goals: aborted at once with the reason
        wall = occupied_cell_near(grid, *WALL_NEAR)
        nan = float("nan")
        cases = [
            ("wall", mb.make_goal(*wall), "obstacle"),
            ("off map", mb.make_goal(50.0, 50.0), "off the map"),
            ("unknown space", mb.make_goal(-2.7, 0.0), "unknown space"),
            ("NaN", mb.make_goal(nan, 1.0), "NaN"),
            ("non-unit quaternion", mb.make_goal(1.0, 0.0, q=(0.0, 0.0, 0.0, 0.5)), "unit quaternion"),
            ("tilted quaternion", mb.make_goal(1.0, 0.0, q=(0.7071068, 0.0, 0.0, 0.7071068)), "rotation about z"),
            ("unknown frame", mb.make_goal(1.0, 0.0, frame="nowhere"), "cannot transform"),
        ]
        for name, goal, reason in cases:
            t0 = rospy.Time.now()
            fb = []
            c.send_goal(goal, feedback_cb=fb.append)
            state, text = mb.wait_result(c, 30.0)
            took = (rospy.Time.now() - t0).to_sec()
            print(f"BAD_GOAL {name}: {state} after {took:.2f} s sim, {len(fb)} feedback: {text}")
            self.assertEqual(state, "ABORTED", f"{name}: {text}")
            self.assertIn(reason, text, name)
            self.assertIn("invalid goal", text, name)
            self.assertEqual(len(fb), 0, f"{name}: pursued for {len(fb)} control cycles before the abort")

        # 3. services
        gcost = waits.Latest("/move_base/global_costmap/costmap", OccupancyGrid)
        rospy.wait_for_service("/move_base/make_plan", 30.0)
        make_plan = rospy.ServiceProxy("/move_base/make_plan", GetPlan)

        def req(x, y, frame="map", tol=0.0):
            r = GetPlanRequest()
            r.goal = PoseStamped()
            r.goal.header.frame_id = frame
            r.goal.pose.position.x, r.goal.pose.position.y = x, y
            r.goal.pose.orientation.w = 1.0
            r.tolerance = tol
            return make_plan(r).plan

        p = req(*ROOM)
        self.assertEqual(p.header.frame_id, "map")
        self.assertGreater(len(p.poses), 50)
        self.assertAlmostEqual(p.poses[-1].pose.position.x, ROOM[0], places=3)
        self.assertAlmostEqual(p.poses[-1].pose.position.y, ROOM[1], places=3)
        self.assertEqual(len(req(*wall).poses), 0)
        # a goal 0.1 m inside the inscribed zone (walking from the hall toward the wall in the
        # published global costmap): planned to free space within default_tolerance
        g = gcost.wait()
        costs = np.asarray(g.data, dtype=np.int16).reshape(g.info.height, g.info.width)
        res, ox, oy = g.info.resolution, g.info.origin.position.x, g.info.origin.position.y
        row = int((wall[1] - oy) / res)
        col = int((wall[0] - 1.5 - ox) / res)
        while costs[row, col] < 99:
            col += 1
        near = (ox + (col + 0.5) * res + 0.1, wall[1])
        p = req(*near)
        self.assertGreater(len(p.poses), 0)
        end = p.poses[-1].pose.position
        self.assertLessEqual(math.hypot(end.x - near[0], end.y - near[1]), 0.2 + 1e-6)
        # a goal in base_footprint: 1 m ahead of the robot, wherever step 1 left it (it may
        # have turned toward the room before the cancel)
        before = robot_in_map(tf_buf)
        p = req(1.0, 0.0, frame="base_footprint")
        after = robot_in_map(tf_buf)
        self.assertLess(math.hypot(after[0] - before[0], after[1] - before[1]), 0.01, "the robot moved")
        ahead = compose(before, (1.0, 0.0, 0.0))
        print(f"ROBOT at ({before[0]:.3f}, {before[1]:.3f}, {before[2]:.3f} rad); 1 m ahead is "
              f"({ahead[0]:.3f}, {ahead[1]:.3f})")
        self.assertGreater(len(p.poses), 0)
        end = p.poses[-1].pose.position
        self.assertLess(math.hypot(end.x - ahead[0], end.y - ahead[1]), 0.1)
        rospy.wait_for_service("/move_base/clear_costmaps", 10.0)
        rospy.ServiceProxy("/move_base/clear_costmaps", Empty)()
        rosout.wait("move_base", "costmaps cleared")


if __name__ == "__main__":
    rostest.rosrun("my_summit_path_planning", "move_base_bad_goals", MoveBaseBadGoals, sys.argv)
