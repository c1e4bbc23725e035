#!/usr/bin/python3
"""rostest: frontier exploration maps the reachable building without a driver.

Waits for /explore/done; then judges slam_gmapping's last map against the simulator's
world: the share of the reachable free area (the free space connected to the spawn
point) that the map knows must be >= ~min_coverage; the explore node must end because no
(reachable) frontier is left (its summary matching ~summary_regex) and save the map; zero
collisions. ~robot_radius [m]: the reachable area is where a disc of that radius can go
(space seen through a gap narrower than the robot does not count); 0: all connected free
space.
"""
import os
import sys
import time
import unittest

import numpy as np
import rospy
import rostest
from nav_msgs.msg import OccupancyGrid
from rospy.numpy_msg import numpy_msg
from std_msgs.msg import Bool, String, UInt32

from my_summit_navigation.frontiers import exploration_coverage
from summit_nav_common.map_io import load_map


class Explore(unittest.TestCase):
    def test_explores_the_reachable_area(self):
        rospy.init_node("explore_test")
        state = {"done": False, "coll": 0, "map": None, "summary": None}
        rospy.Subscriber("/explore/done", Bool, lambda m: state.update(done=m.data), queue_size=1)
        rospy.Subscriber("/explore/summary", String, lambda m: state.update(summary=m.data), queue_size=1)
        rospy.Subscriber("/collisions", UInt32, lambda m: state.update(coll=max(state["coll"], m.data)), queue_size=5)
        rospy.Subscriber("/map", numpy_msg(OccupancyGrid), lambda m: state.update(map=m), queue_size=1,
                         buff_size=2 ** 25)
        end = time.monotonic() + rospy.get_param("~timeout_wall")
        while not (state["done"] and state["summary"]) and time.monotonic() < end and not rospy.is_shutdown():
            time.sleep(0.5)
        self.assertTrue(state["done"], f"exploration not over in time; last summary {state['summary']}")
        world = load_map(rospy.get_param("/summit_xl_sim/world"))
        spawn = tuple(float(rospy.get_param("/summit_xl_sim/" + k)) for k in ("x", "y", "yaw"))
        m = state["map"]
        slam = np.asarray(m.data, np.int8).reshape(m.info.height, m.info.width)
        cov = exploration_coverage(world.data, world.resolution, world.origin[:2], spawn, slam, m.info.resolution,
                                   (m.info.origin.position.x, m.info.origin.position.y),
                                   robot_radius=float(rospy.get_param("~robot_radius", 0.0)))
        print(f"EXPLORE coverage={cov:.3f} collisions={state['coll']} summary={state['summary']!r}", flush=True)
        rospy.loginfo(f"explore test: coverage {cov:.3f}; {state['summary']}")
        # over because nothing is left to explore (a pocket move_base cannot reach may be
        # blacklisted on the way), not because of a time limit
        self.assertRegex(state["summary"], rospy.get_param("~summary_regex", r"no (reachable )?frontiers? left"))
        self.assertIn("saved to", state["summary"])
        base = state["summary"].split("saved to ")[1].split(".pgm")[0]
        self.assertTrue(os.path.exists(base + ".yaml") and os.path.exists(base + ".pgm"))
        self.assertGreaterEqual(cov, rospy.get_param("~min_coverage"))
        self.assertEqual(state["coll"], 0, "the robot collided")


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "explore_two_rooms", Explore, sys.argv)
