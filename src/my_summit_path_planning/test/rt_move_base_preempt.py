#!/usr/bin/python3
"""rostest: a new goal preempts the active one; a cancel preempts too.

The first goal (the fetch room) is sent through the action; once the robot drives, a
second goal (in the hall) comes on move_base_simple/goal, as rviz's 2D Nav Goal sends
it. The first must end PREEMPTED, the second (seen on move_base/result with its own
goal id) SUCCEEDED within the goal tolerance by ground truth, with zero collisions.
Then a third goal is canceled while active: PREEMPTED, and the robot stops.
"""
import math
import sys
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseActionResult

from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits

AMCL_MARGIN = 0.10   # [m]


class MoveBasePreempt(unittest.TestCase):
    def test_new_goal_preempts(self):
        rospy.init_node("move_base_preempt_test")
        first = (rospy.get_param("~first_x"), rospy.get_param("~first_y"))
        second = (rospy.get_param("~second_x"), rospy.get_param("~second_y"))
        xy_tol = rospy.get_param("/move_base/DWAPlannerROS/xy_goal_tolerance")
        truth = gt.Truth(gt.map_in_world())
        results = []
        rospy.Subscriber("/move_base/result", MoveBaseActionResult, results.append, queue_size=20)
        simple = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1, latch=True)
        waits.wait_clock()
        c = mb.client()
        start = truth.wait()
        waits.sleep_sim(2.0)
        c.send_goal(mb.make_goal(*first))
        waits.wait_for(lambda: math.hypot(truth.pose[0] - start[0], truth.pose[1] - start[1]) > 1.0,
                       "the robot driving toward the first goal", 120.0)
        self.assertEqual(mb.state_name(c), "ACTIVE")
        ps = mb.make_goal(second[0], second[1], math.pi / 2).target_pose
        ps.header.stamp = rospy.Time.now()
        t0 = rospy.Time.now()
        simple.publish(ps)
        state, text = mb.wait_result(c, 10.0)
        print(f"PREEMPT first goal: {state}: {text!r}")
        self.assertEqual(state, "PREEMPTED", text)

        def second_result():   # move_base names the goals it makes of move_base_simple/goal so
            return [r for r in results if r.status.goal_id.id.startswith("move_base_simple")]
        waits.wait_for(lambda: second_result(), "a result of the second goal", 300.0)
        r = second_result()[0]
        took = (rospy.Time.now() - t0).to_sec()
        waits.sleep_sim(0.5)
        end = truth.pose
        err = math.hypot(end[0] - second[0], end[1] - second[1])
        print(f"PREEMPT second goal: status {mb.STATE_NAMES.get(r.status.status)} after {took:.1f} s sim, "
              f"final error {err:.3f} m, collisions {truth.collisions}: {r.status.text!r}")
        self.assertEqual(r.status.status, 3, r.status.text)   # SUCCEEDED
        self.assertLessEqual(err, xy_tol + AMCL_MARGIN)
        self.assertEqual(truth.collisions, 0)

        # cancel while active
        c.send_goal(mb.make_goal(*first))
        here = truth.pose
        waits.wait_for(lambda: math.hypot(truth.pose[0] - here[0], truth.pose[1] - here[1]) > 0.5,
                       "the robot driving toward the third goal", 120.0)
        c.cancel_goal()
        state, text = mb.wait_result(c, 10.0)
        self.assertEqual(state, "PREEMPTED", text)
        waits.sleep_sim(1.5)
        stopped = truth.pose
        waits.sleep_sim(1.0)
        self.assertLess(math.hypot(truth.pose[0] - stopped[0], truth.pose[1] - stopped[1]), 0.02,
                        "the robot should stand after a cancel")
        self.assertEqual(truth.collisions, 0)


if __name__ == "__main__":
    rostest.rosrun("my_summit_path_planning", "move_base_preempt", MoveBasePreempt, sys.argv)
