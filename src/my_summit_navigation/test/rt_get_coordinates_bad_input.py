#!/usr/bin/python3
"""rostest: /get_coordinates refuses bad input and says why; a newer call preempts.

Through the service (as `rosservice call` does):
1. unknown label (the answer lists the known labels); empty and blank labels;
2. a server whose spots file is missing, one whose spots file is malformed: they run,
   and answer every call false naming the file and the fault;
3. a server whose move_base action does not exist: false "move_base not available"
   after its ~server_timeout;
   (the robot has not moved through any of these)
4. a spot in a wall: false with move_base's abort text;
5. preemption: a call to the fetch room, then, while the robot drives, a newer call to a
   spot in the hall: the older answers false "preempted by a newer call", the newer "OK"
   with the robot within 0.3 m / 0.3 rad of its spot by ground truth;
then the stand-alone client send_coordinates_action_client.py: x y yaw back to the start
(exit 0, feedback printed, SUCCEEDED), an unknown label (exit 2, nothing sent), and no
move_base (exit 1). Zero collisions over the whole run.
"""
import os
import subprocess
import sys
import threading
import time
import unittest

import rospkg
import rospy
import rostest

from my_summit_localization.spots import load_spots
from my_summit_navigation.srv import MyServiceMessage

sys.path.insert(0, os.path.join(rospkg.RosPack().get_path("my_summit_path_planning"), "test"))
import mbtest_util as mt  # noqa: E402
from mbtest_util import lu  # noqa: E402

SERVICE_WAIT = 120.0   # [s] wall: the stack may take a while to come up under load
NO_SERVER_TIMEOUT = 2.0   # [s] the gc_no_move_base server's ~server_timeout (the .test)
XY_TOL, YAW_TOL = 0.3, 0.3   # [m], [rad] by ground truth
CLI_TIMEOUT = 300.0   # [s] wall bound of one command-line client run
STILL = 0.05          # [m] the robot "has not moved"


def proxy(name):
    rospy.wait_for_service(name, SERVICE_WAIT)
    return rospy.ServiceProxy(name, MyServiceMessage)


def run_client(*args):
    """(exit code, output) of send_coordinates_action_client.py with args."""
    p = subprocess.run(["rosrun", "my_summit_navigation", "send_coordinates_action_client.py", *args],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=CLI_TIMEOUT)
    print(f"CLI {' '.join(args)} -> exit {p.returncode}:\n{p.stdout}", flush=True)
    return p.returncode, p.stdout


class GetCoordinatesBadInput(unittest.TestCase):
    def test_bad_input_and_preemption(self):
        rospy.init_node("get_coordinates_bad_input_test")
        missing = rospy.get_param("~missing_file")
        malformed = rospy.get_param("~malformed_file")
        hall_file = rospy.get_param("~hall_file")
        _, hall = load_spots(hall_file)
        rosout = lu.RosoutWatcher()
        truth = mt.Truth(lu.map_in_world())
        lu.wait_clock()
        main = proxy("/get_coordinates")
        missing_srv = proxy("/missing/get_coordinates")
        malformed_srv = proxy("/malformed/get_coordinates")
        no_mb = proxy("/no_move_base/get_coordinates")
        hall_srv = proxy("/hall/get_coordinates")
        mt.client()
        start = truth.wait()
        lu.sleep_sim(2.0)

        # 1. labels
        r = main("kitchen")
        self.assertFalse(r.navigation_successfull)
        self.assertEqual(r.message, "unknown label 'kitchen'; known labels: room, turtle, table")
        for empty in ("", "   "):
            r = main(empty)
            self.assertFalse(r.navigation_successfull)
            self.assertTrue(r.message.startswith("the label is empty"), r.message)
            self.assertIn("room, turtle, table", r.message)

        # 2. unusable spots files: every call refused, naming the file and the fault
        mark = rosout.mark()
        for label in ("room", "", "kitchen"):
            r = missing_srv(label)
            self.assertFalse(r.navigation_successfull)
            self.assertIn(missing, r.message)
            self.assertIn("cannot read the spots file", r.message)
            r = malformed_srv(label)
            self.assertFalse(r.navigation_successfull)
            self.assertIn(malformed, r.message)
            self.assertIn("malformed YAML", r.message)
        self.assertIn(malformed, rosout.wait("gc_malformed_file", "malformed YAML", mark))
        self.assertIn(missing, rosout.wait("gc_missing_file", "cannot read", mark))

        # 3. no move_base behind the action name
        t0 = rospy.Time.now()
        r = no_mb("room")
        took = (rospy.Time.now() - t0).to_sec()
        print(f"NO_MOVE_BASE after {took:.2f} s sim: {r.message!r}", flush=True)
        self.assertFalse(r.navigation_successfull)
        self.assertTrue(r.message.startswith("move_base not available"), r.message)
        self.assertIn("/no_such_move_base", r.message)
        self.assertGreaterEqual(took, NO_SERVER_TIMEOUT - 0.1)
        here = truth.pose
        self.assertLess(lu.pose_error(here, start)[0], STILL, "no call so far should have moved the robot")

        # 4. a spot in a wall: move_base aborts, and its reason is passed on
        t0 = rospy.Time.now()
        r = hall_srv("wall")
        print(f"ABORTED after {(rospy.Time.now() - t0).to_sec():.2f} s sim: {r.message!r}", flush=True)
        self.assertFalse(r.navigation_successfull)
        self.assertTrue(r.message.startswith("move_base aborted the goal: "), r.message)
        self.assertIn("invalid goal", r.message)

        # 5. preemption by a newer call
        answers = {}

        def older():
            answers["far"] = hall_srv("far")
            answers["far_at"] = rospy.Time.now()

        thread = threading.Thread(target=older, daemon=True)
        thread.start()
        here = truth.pose
        lu.wait_for(lambda: lu.pose_error(truth.pose, here)[0] > 1.0, "the robot driving toward 'far'", 200.0)
        self.assertNotIn("far", answers, "the first call should still be running")
        t0 = rospy.Time.now()
        r = hall_srv("near")
        took = (rospy.Time.now() - t0).to_sec()
        thread.join(30.0)
        lu.sleep_sim(0.5)
        near = hall["near"]
        err_xy, err_yaw = lu.pose_error(truth.pose, (near.x, near.y, near.yaw))
        far = answers["far"]
        print(f"PREEMPT older: {far.message!r} after {(answers['far_at'] - t0).to_sec():.2f} s sim; newer: "
              f"{r.message!r} after {took:.1f} s sim, error {err_xy:.3f} m {err_yaw:.3f} rad", flush=True)
        self.assertFalse(far.navigation_successfull)
        self.assertEqual(far.message, "preempted by a newer call (label 'near')")
        self.assertLess((answers["far_at"] - t0).to_sec(), 2.0, "the older call should answer at once")
        self.assertTrue(r.navigation_successfull, r.message)
        self.assertEqual(r.message, "OK")
        self.assertLessEqual(err_xy, XY_TOL)
        self.assertLessEqual(err_yaw, YAW_TOL)

        # the stand-alone action client
        rc, out = run_client("0.0", "0.0", "0.0")
        self.assertEqual(rc, 0, out)
        self.assertIn("feedback: robot at", out)
        self.assertIn("result: SUCCEEDED", out)
        lu.sleep_sim(0.5)
        err_xy, err_yaw = lu.pose_error(truth.pose, (0.0, 0.0, 0.0))
        print(f"CLI x y yaw: final error {err_xy:.3f} m {err_yaw:.3f} rad", flush=True)
        self.assertLessEqual(err_xy, XY_TOL)
        self.assertLessEqual(err_yaw, YAW_TOL)
        rc, out = run_client("kitchen")
        self.assertEqual(rc, 2, out)
        self.assertIn("unknown label 'kitchen'; known labels: room, turtle, table", out)
        rc, out = run_client("near", "--spots-file", hall_file, "--action", "/no_such_move_base",
                             "--server-timeout", "1.0")
        self.assertEqual(rc, 1, out)
        self.assertIn("move_base not available", out)
        self.assertEqual(truth.collisions, 0, "the robot collided")


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "get_coordinates_bad_input", GetCoordinatesBadInput, sys.argv)
