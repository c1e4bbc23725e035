#!/usr/bin/python3
"""rostest: a goal the robot cannot reach runs the recovery chain, then aborts with why.

Four boxes (the simulator's add_box, world frame) ring the robot at its spawn pose with
room to turn in place but no gap to leave by. A goal outside the ring: once the laser
has put the ring into the costmaps there is no plan (or no valid command), and move_base
must run its default recoveries in order (conservative_reset, rotate_recovery,
aggressive_reset, rotate_recovery), or the recovery_behaviors list it was given (~order:
the names expected), as logged and as published on move_base/recovery_status, then end
ABORTED with move_base's text plus the last
failure's reason. Zero collisions by ground truth, and the robot still in the ring.
"""
import math
import sys
import threading
import unittest

import rospy
import rostest
from move_base_msgs.msg import RecoveryStatus
from rosgraph_msgs.msg import Log

from summit_xl_sim.srv import AddBox

from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits

DEFAULT_ORDER = ["conservative_reset", "rotate_recovery", "aggressive_reset", "rotate_recovery"]
ABORT_TEXTS = ("Failed to find a valid plan. Even after executing recovery behaviors.",
               "Failed to find a valid control. Even after executing recovery behaviors.",
               "Robot is oscillating. Even after executing recovery behaviors.")


class RosoutRecoveries:
    """move_base's 'recovery behaviour i/n: name' lines from /rosout, in order, and its
    move_base/recovery_status messages."""

    def __init__(self):
        self.lock = threading.Lock()
        self.names = []
        self.statuses = []
        rospy.Subscriber("/rosout", Log, self._cb, queue_size=100)
        rospy.Subscriber("/move_base/recovery_status", RecoveryStatus, self._status, queue_size=100)

    def _status(self, msg):
        p = msg.pose_stamped
        with self.lock:
            self.statuses.append((msg.current_recovery_number, msg.total_number_of_recoveries,
                                  msg.recovery_behavior_name, p.header.frame_id, p.pose.position.x,
                                  p.pose.position.y))

    def _cb(self, msg):
        marker = "move_base: recovery behaviour "
        if msg.name.endswith("move_base") and marker in msg.msg:
            with self.lock:
                self.names.append(msg.msg.split(marker, 1)[1].split(": ", 1)[1].strip())


class MoveBaseRecovery(unittest.TestCase):
    def test_recoveries_in_order_then_abort(self):
        rospy.init_node("move_base_recovery_test")
        goal = (rospy.get_param("~goal_x"), rospy.get_param("~goal_y"), rospy.get_param("~goal_yaw"))
        inner = rospy.get_param("~ring_inner")
        wall = rospy.get_param("~ring_wall")
        max_sim = rospy.get_param("~max_sim_time")
        order = rospy.get_param("~order", DEFAULT_ORDER)
        m_in_w = gt.map_in_world()
        truth = gt.Truth(m_in_w)
        log = RosoutRecoveries()
        waits.wait_clock()
        c = mb.client()
        rospy.wait_for_service("/summit_xl_sim/add_box", 30.0)
        add_box = rospy.ServiceProxy("/summit_xl_sim/add_box", AddBox)
        x, y, yaw = truth.wait()
        mb.ring_robot(add_box, (x, y, yaw), m_in_w, inner, wall)
        waits.sleep_sim(1.0)   # a few scans of the ring
        c.send_goal(mb.make_goal(*goal))
        state, text = mb.wait_result(c, max_sim)
        end = truth.pose
        waits.sleep_sim(0.5)   # the last recovery_status and rosout lines in flight
        with log.lock:
            names = list(log.names)
            statuses = list(log.statuses)
        print(f"MOVE_BASE_RECOVERY state={state} recoveries={names} collisions={truth.collisions} "
              f"moved_m={math.hypot(end[0] - x, end[1] - y):.2f} text={text!r}")
        self.assertEqual(state, "ABORTED", text)
        # move_base starts the chain over when a valid plan comes back meanwhile (as the
        # real one does): each run of the chain is a prefix of the order, and the last
        # one, which ends in the abort, is the whole of it.
        runs = []
        for n in names:
            if n == order[0] or not runs:
                runs.append([])
            runs[-1].append(n)
        self.assertTrue(runs, "no recovery behaviour was logged")
        for r in runs:
            self.assertEqual(r, order[:len(r)], f"recoveries out of the order {order}: {names}")
        self.assertEqual(runs[-1], order, f"the last chain before the abort is not complete: {names}")
        # move_base/recovery_status: one message per recovery run, as the log says, each with
        # its 0-based number in the list, the list's length and the robot's pose in the map
        # frame (amcl's: boxed in by walls the map lacks, amcl may be a metre or two off)
        self.assertEqual([st[2] for st in statuses], names, f"recovery_status {statuses} vs the log {names}")
        for number, total, name, frame, _, _ in statuses:
            self.assertEqual((total, order[number], frame), (len(order), name, "map"), statuses)
        self.assertTrue(text.startswith(ABORT_TEXTS), f"abort text without move_base's reason: {text!r}")
        self.assertIn("Last failure: ", text, "the abort text does not say what failed last")
        self.assertGreater(len(text.split("Last failure: ", 1)[1]), 10)
        self.assertEqual(truth.collisions, 0)
        self.assertLess(math.hypot(end[0] - x, end[1] - y), inner, "the robot left the ring")


if __name__ == "__main__":
    rostest.rosrun("my_summit_path_planning", "move_base_recovery", MoveBaseRecovery, sys.argv)
