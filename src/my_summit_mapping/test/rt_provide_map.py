#!/usr/bin/python3
"""rostest: provide_map.launch serves the committed map exactly as map_io loads it."""
import unittest

import numpy as np
import rospy
import rostest
from nav_msgs.msg import MapMetaData, OccupancyGrid
from nav_msgs.srv import GetMap
from numpy.testing import assert_allclose, assert_array_equal
from summit_nav_common.map_io import load_map

from summit_nav_common.ros import map_msgs

TIMEOUT = 20.0  # [s] for a latched message or the service


class ProvideMap(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("provide_map_test")
        cls.expected = load_map(rospy.get_param("~map_file"))

    def check(self, msg):
        self.assertEqual(msg.header.frame_id, "map")
        grid = map_msgs.msg_to_grid(msg)
        self.assertEqual((grid.width, grid.height), (self.expected.width, self.expected.height))
        self.assertAlmostEqual(grid.resolution, self.expected.resolution, places=6)
        assert_allclose(grid.origin, self.expected.origin, atol=1e-6)
        assert_array_equal(grid.data, self.expected.data)
        # the committed map is a real map: walls, free space and unknown
        self.assertEqual(set(np.unique(grid.data)), {-1, 0, 100})

    def test_1_map_latched(self):
        self.check(rospy.wait_for_message("/map", OccupancyGrid, timeout=TIMEOUT))

    def test_2_metadata_latched(self):
        rospy.sleep(0.5)  # subscribe well after the publication: only a latched topic answers
        meta = rospy.wait_for_message("/map_metadata", MapMetaData, timeout=TIMEOUT)
        self.assertEqual((meta.width, meta.height), (self.expected.width, self.expected.height))
        self.assertAlmostEqual(meta.resolution, self.expected.resolution, places=6)
        self.assertAlmostEqual(meta.origin.position.x, self.expected.origin[0], places=6)
        self.assertAlmostEqual(meta.origin.position.y, self.expected.origin[1], places=6)

    def test_3_static_map_service(self):
        rospy.wait_for_service("/static_map", timeout=TIMEOUT)
        self.check(rospy.ServiceProxy("/static_map", GetMap)().map)


if __name__ == "__main__":
    rostest.rosrun("my_summit_mapping", "provide_map", ProvideMap)
