#!/usr/bin/python3
"""rostest: adaptive_params switches move_base's parameters through dynamic_reconfigure.

adaptive_params.test starts the course building's move_base (DWAPlannerROS) and
adaptive_params with an enter threshold below the start pose's clutter. Asserted on the
servers themselves (not on the node's log): before the switch they hold the course's
values (max_vel_x 1.0 m/s, inflation_radius 0.8 m); once ~state is "cluttered", the DWA
planner's max_vel_x is 0.25 m/s and both inflation layers' inflation_radius 1.1 m; ~clutter
carries the share that caused it (>= the enter threshold).
"""
import unittest

import rospy
import rostest
from dynamic_reconfigure.client import Client
from std_msgs.msg import Float32, String

WAIT = 120.0   # [s] wall time for the switch (move_base start, first costmap, dwell)


class AdaptiveParams(unittest.TestCase):
    def test_clutter_switches_the_servers(self):
        rospy.init_node("adaptive_params_test")
        planner = Client("/move_base/DWAPlannerROS", timeout=WAIT)
        local = Client("/move_base/local_costmap/inflation_layer", timeout=WAIT)
        global_ = Client("/move_base/global_costmap/inflation_layer", timeout=WAIT)
        states = []
        sub = rospy.Subscriber("/adaptive_params/state", String, lambda m: states.append(m.data))
        deadline = rospy.Time.now() + rospy.Duration(WAIT)   # ROS time: the test runs at 2x
        while not states and rospy.Time.now() < deadline:
            rospy.sleep(0.1)
        if states == ["open"]:   # the latched start state; the switch comes after the dwell
            self.assertAlmostEqual(planner.get_configuration(5.0)["max_vel_x"], 1.0)
            self.assertAlmostEqual(local.get_configuration(5.0)["inflation_radius"], 0.8)
        while "cluttered" not in states and rospy.Time.now() < deadline:
            rospy.sleep(0.1)
        sub.unregister()
        self.assertEqual(states[-1:], ["cluttered"])
        clutter = rospy.wait_for_message("/adaptive_params/clutter", Float32, timeout=30.0)
        self.assertGreaterEqual(clutter.data, rospy.get_param("/adaptive_params/leave_clutter"))
        self.assertAlmostEqual(planner.get_configuration(5.0)["max_vel_x"], 0.25)
        self.assertAlmostEqual(local.get_configuration(5.0)["inflation_radius"], 1.1)
        self.assertAlmostEqual(global_.get_configuration(5.0)["inflation_radius"], 1.1)


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "adaptive_params_switch", AdaptiveParams)
