#!/usr/bin/python3
"""rostest: a dynamic_reconfigure call changes the planner's behaviour while it runs.

1. /move_base/DWAPlannerROS max_vel_x and max_vel_trans set to 0.3: a goal across the
   hall is then driven with cmd_vel's linear.x never above 0.3 (and above 0.2: it did
   drive at the new limit), and reached;
2. max_vel_x 50 (the .cfg's range is [-20, 20]) is refused: the server keeps 0.3;
3. min_vel_x above max_vel_x is refused (the planner could not run with it);
4. the global costmap's inflation_layer inflation_radius 0.3 -> the costmap republished
   has fewer inflated cells than before; amcl max_particles 2000 accepted, 99999 refused.
"""
import sys
import threading
import unittest

import numpy as np
import rospy
import rostest
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import Twist
from summit_nav_common.ros.costmap_client import CostmapClient

from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits


class Reconfigure(unittest.TestCase):
    def test_reconfigure_changes_behaviour(self):
        rospy.init_node("move_base_reconfigure_test")
        waits.wait_clock()
        client = mb.client()
        truth = gt.Truth(gt.spawn_in_world())
        truth.wait()
        dwa = Client("/move_base/DWAPlannerROS", timeout=60)
        cfg = dwa.update_configuration({"max_vel_x": 0.3, "max_vel_trans": 0.3})
        self.assertAlmostEqual(cfg["max_vel_x"], 0.3)
        top = {"vx": 0.0}
        lock = threading.Lock()

        def on_cmd(msg):
            with lock:
                top["vx"] = max(top["vx"], msg.linear.x)
        rospy.Subscriber("/summit_xl_control/cmd_vel", Twist, on_cmd, queue_size=50)
        client.send_goal(mb.make_goal(6.0, 0.0, 0.0))
        state, text = mb.wait_result(client, 120.0)
        self.assertEqual(state, "SUCCEEDED", text)
        print(f"RECONFIGURE top_cmd_vx={top['vx']:.3f}", flush=True)
        self.assertLessEqual(top["vx"], 0.3 + 1e-6)
        self.assertGreater(top["vx"], 0.2)
        cfg = dwa.update_configuration({"max_vel_x": 50.0})
        self.assertAlmostEqual(cfg["max_vel_x"], 0.3, msg="an out-of-range value must be refused")
        cfg = dwa.update_configuration({"min_vel_x": 1.0})
        self.assertAlmostEqual(cfg["min_vel_x"], 0.0, msg="min_vel_x > max_vel_x must be refused")

        counts = []

        def on_costmap(client):
            data = client.snapshot()[2]
            counts.append(int(np.count_nonzero((data > 0) & (data < 99))))
        # the whole grid once, then the redrawn windows on costmap_updates (costmap_2d's way)
        CostmapClient("/move_base/global_costmap/costmap", on_costmap)
        waits.wait_for(lambda: len(counts) > 0, "the global costmap")
        before = counts[-1]
        infl = Client("/move_base/global_costmap/inflation_layer", timeout=30)
        cfg = infl.update_configuration({"inflation_radius": 0.4})
        self.assertAlmostEqual(cfg["inflation_radius"], 0.4)
        n = len(counts)
        waits.wait_for(lambda: len(counts) > n + 1, "the global costmap after reconfigure")
        print(f"RECONFIGURE inflated_cells before={before} after={counts[-1]}", flush=True)
        self.assertLess(counts[-1], before * 0.8)

        amcl = Client("/amcl", timeout=30)
        self.assertEqual(amcl.update_configuration({"max_particles": 2000})["max_particles"], 2000)
        self.assertEqual(amcl.update_configuration({"max_particles": 99999})["max_particles"], 2000)
        self.assertEqual(truth.collisions, 0)


if __name__ == "__main__":
    rostest.rosrun("my_summit_path_planning", "move_base_reconfigure", Reconfigure, sys.argv)
