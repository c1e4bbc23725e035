#!/usr/bin/python3
"""rostest: the patrol reaches the reachable spots, skips the blocked ones with the
reason, and goes home when asked.

patrol_blocked.test runs the patrol forever over table, in_desk, ghost, room, turtle.
Once move_base has reported a goal reached (/move_base/result SUCCEEDED) with the robot
at table, at room and at turtle by ground truth (within 0.3 m), /patrol/return_home is
called (not sooner: a robot standing at a spot may still be turning to its heading, and
cancelling then leaves the spot unreached in the summary); then: the summary names 'in_desk' (move_base's abort reason, after a retry) and
'ghost' (unknown label) as skipped, at least table, room and turtle reached; every
reachable spot was visited within 0.3 m by ground truth; the robot ends within 0.3 m of
where it started; zero collisions.
"""
import math
import sys
import unittest

import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseActionResult
from std_msgs.msg import String
from std_srvs.srv import Trigger

from my_summit_localization.spots import load_spots

from summit_nav_common.testing import ground_truth as gt, waits

REACHABLE = ("table", "room", "turtle")
TOL = 0.3   # [m] by ground truth


class PatrolBlocked(unittest.TestCase):
    def test_patrol_skips_blocked_and_returns_home(self):
        rospy.init_node("patrol_blocked_test")
        _, spots = load_spots(rospy.get_param("~spots_file"))
        # The nominal map frame (the spawn pose; registration would take this node longer
        # to start than the patrol takes to its first spot). The patrol's home is where
        # the robot stood when it started: the map's origin.
        truth = gt.Truth(gt.spawn_in_world())
        waits.wait_clock()
        truth.wait()
        start = (0.0, 0.0, 0.0)
        summary = waits.Latest("/patrol/summary", String)
        visited = set()

        def near(label):
            x, y, _ = truth.pose
            return math.hypot(x - spots[label].x, y - spots[label].y) <= TOL

        def on_result(msg):
            if msg.status.status == GoalStatus.SUCCEEDED and truth.pose is not None:
                visited.update(label for label in REACHABLE if near(label))
        rospy.Subscriber("/move_base/result", MoveBaseActionResult, on_result, queue_size=10)

        def round_done():
            return visited == set(REACHABLE)
        waits.wait_for(round_done, "the robot at table, room and turtle (a patrol round)", timeout_wall=450.0)
        rospy.wait_for_service("/patrol/return_home", 10.0)
        resp = rospy.ServiceProxy("/patrol/return_home", Trigger)()
        self.assertTrue(resp.success, resp.message)
        msg = summary.wait(timeout_wall=240.0)
        text = msg.data
        rospy.loginfo(f"patrol summary: {text}")
        print(f"PATROL summary={text!r} visited={sorted(visited)} collisions={truth.collisions}", flush=True)
        waits.sleep_sim(1.0)
        end = truth.pose
        self.assertEqual(set(REACHABLE), visited, f"visited {sorted(visited)}; summary: {text}")
        self.assertIn("'in_desk' (move_base aborted", text)
        self.assertIn("after 2 tries", text)
        self.assertIn("'ghost' (unknown label 'ghost'", text)
        reached = int(text.split("reached ")[1].split(",")[0])
        self.assertGreaterEqual(reached, 3, text)
        self.assertLessEqual(math.hypot(end[0] - start[0], end[1] - start[1]), TOL, f"not home: {end} vs {start}")
        self.assertEqual(truth.collisions, 0, "the robot collided")


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "patrol_blocked", PatrolBlocked, sys.argv)
