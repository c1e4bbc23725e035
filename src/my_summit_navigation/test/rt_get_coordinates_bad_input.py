#!/usr/bin/python3
"""rostest: /get_coordinates and the stand-alone client refuse bad input and say why.

One test per bad input, each on its own (any order, any outcome of the others); none
of them may move the robot, and each checks that it did not:
- through the service (as `rosservice call` does): an unknown label (the answer lists
  the known labels), an empty label, a blank one; a server whose spots file is missing,
  one whose spots file is malformed (they run, and answer every call false naming the
  file and the fault, also on /rosout); a server whose move_base action does not exist
  (false "move_base not available" after its ~server_timeout); a spot inside a wall
  (false with move_base's abort text);
- the command-line client send_coordinates_action_client.py: an unknown label (exit 2,
  nothing sent), no move_base behind the action name (exit 1).
The driving cases (preemption, the client driving to x y yaw) are rt_get_coordinates_drives.py.
"""
import subprocess
import sys
import unittest

import rospy
import rostest

from my_summit_navigation.srv import MyServiceMessage

from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits

SERVICE_WAIT = 120.0   # [s] wall: the stack may take a while to come up under load
NO_SERVER_TIMEOUT = 2.0   # [s] the gc_no_move_base server's ~server_timeout (the .test)
CLI_TIMEOUT = 120.0    # [s] wall bound of one command-line client run (none of these drives)
STILL = 0.05           # [m] the robot "has not moved"
KNOWN = "room, turtle, table"   # the labels of the committed spots.yaml, in file order


def run_client(*args):
    """(exit code, output) of send_coordinates_action_client.py with args."""
    p = subprocess.run(["rosrun", "my_summit_navigation", "send_coordinates_action_client.py", *args],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=CLI_TIMEOUT)
    print(f"CLI {' '.join(args)} -> exit {p.returncode}:\n{p.stdout}", flush=True)
    return p.returncode, p.stdout


class GetCoordinatesBadInput(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("get_coordinates_bad_input_test")
        cls.missing = rospy.get_param("~missing_file")
        cls.malformed = rospy.get_param("~malformed_file")
        cls.hall_file = rospy.get_param("~hall_file")
        cls.rosout = waits.RosoutWatcher()
        cls.truth = gt.Truth(gt.map_in_world())
        waits.wait_clock()
        cls.srv = {}
        for name in ("/get_coordinates", "/missing/get_coordinates", "/malformed/get_coordinates",
                     "/no_move_base/get_coordinates", "/hall/get_coordinates"):
            rospy.wait_for_service(name, SERVICE_WAIT)
            cls.srv[name] = rospy.ServiceProxy(name, MyServiceMessage)
        mb.client()               # move_base is up: the refusals below are not for want of it
        cls.truth.wait()

    def setUp(self):
        self.start = self.truth.pose
        self.collisions = self.truth.collisions

    def assert_still(self):
        """The robot has not moved during the test, nor collided."""
        moved = gt.pose_error(self.truth.pose, self.start)[0]
        self.assertLess(moved, STILL, f"the robot moved {moved:.3f} m")
        self.assertEqual(self.truth.collisions, self.collisions, "the robot collided")

    def call(self, service, label):
        r = self.srv[service](label)
        print(f"{service} {label!r} -> {r.navigation_successfull} {r.message!r}", flush=True)
        return r

    # -- labels --------------------------------------------------------------------------
    def test_unknown_label(self):
        r = self.call("/get_coordinates", "kitchen")
        self.assertFalse(r.navigation_successfull)
        self.assertEqual(r.message, f"unknown label 'kitchen'; known labels: {KNOWN}")
        self.assert_still()

    def check_empty(self, label):
        r = self.call("/get_coordinates", label)
        self.assertFalse(r.navigation_successfull)
        self.assertTrue(r.message.startswith("the label is empty"), r.message)
        self.assertIn(KNOWN, r.message)
        self.assert_still()

    def test_empty_label(self):
        self.check_empty("")

    def test_blank_label(self):
        self.check_empty("   ")

    # -- unusable spots files: every call refused, naming the file and the fault ---------
    def check_unusable_file(self, service, node, path, fault, log_fault):
        mark = self.rosout.mark()
        for label in ("room", "", "kitchen"):
            r = self.call(service, label)
            self.assertFalse(r.navigation_successfull)
            self.assertIn(path, r.message)
            self.assertIn(fault, r.message)
        self.assertIn(path, self.rosout.wait(node, log_fault, mark))
        self.assert_still()

    def test_missing_spots_file(self):
        self.check_unusable_file("/missing/get_coordinates", "gc_missing_file", self.missing,
                                 "cannot read the spots file", "cannot read")

    def test_malformed_spots_file(self):
        self.check_unusable_file("/malformed/get_coordinates", "gc_malformed_file", self.malformed,
                                 "malformed YAML", "malformed YAML")

    # -- move_base ------------------------------------------------------------------------
    def test_no_move_base(self):
        t0 = rospy.Time.now()
        r = self.call("/no_move_base/get_coordinates", "room")
        took = (rospy.Time.now() - t0).to_sec()
        print(f"NO_MOVE_BASE after {took:.2f} s sim", flush=True)
        self.assertFalse(r.navigation_successfull)
        self.assertTrue(r.message.startswith("move_base not available"), r.message)
        self.assertIn("/no_such_move_base", r.message)
        self.assertGreaterEqual(took, NO_SERVER_TIMEOUT - 0.1)
        self.assert_still()

    def test_spot_in_a_wall(self):
        # move_base aborts the goal before driving, and its reason is passed on
        r = self.call("/hall/get_coordinates", "wall")
        self.assertFalse(r.navigation_successfull)
        self.assertTrue(r.message.startswith("move_base aborted the goal: "), r.message)
        self.assertIn("invalid goal", r.message)
        self.assert_still()

    # -- the stand-alone client -------------------------------------------------------------
    def test_cli_unknown_label(self):
        rc, out = run_client("kitchen")
        self.assertEqual(rc, 2, out)
        self.assertIn(f"unknown label 'kitchen'; known labels: {KNOWN}", out)
        self.assert_still()

    def test_cli_no_move_base(self):
        rc, out = run_client("near", "--spots-file", self.hall_file, "--action", "/no_such_move_base",
                             "--server-timeout", "1.0")
        self.assertEqual(rc, 1, out)
        self.assertIn("move_base not available", out)
        self.assert_still()


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "get_coordinates_bad_input", GetCoordinatesBadInput, sys.argv)
