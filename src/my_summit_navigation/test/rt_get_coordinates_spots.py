#!/usr/bin/python3
"""rostest: /get_coordinates drives the robot to each course spot, by label.

The robot starts in the main hall (the map's origin); ~labels are called in order
(table, room, turtle: from the hall into the fetch room and around it). Each call must
answer navigation_successfull true with "OK", and then the robot must stand within
~xy_tolerance [m] and ~yaw_tolerance [rad] of the spot by ground truth (taken into the
map frame with summit_nav_common.testing.ground_truth.map_in_world); zero collisions over the whole run.
"""
import math
import sys
import time
import unittest

import rospy
import rostest

from my_summit_localization.spots import load_spots
from my_summit_navigation.srv import MyServiceMessage

from summit_nav_common.testing import ground_truth as gt, move_base_client as mb, waits

SERVICE_WAIT = 120.0   # [s] wall: the stack may take a while to come up under load


class GetCoordinatesSpots(unittest.TestCase):
    def test_spots_by_label(self):
        rospy.init_node("get_coordinates_spots_test")
        labels = rospy.get_param("~labels")
        xy_tol = rospy.get_param("~xy_tolerance")
        yaw_tol = rospy.get_param("~yaw_tolerance")
        _, spots = load_spots(rospy.get_param("~spots_file"))
        truth = gt.Truth(gt.map_in_world())
        waits.wait_clock()
        rospy.wait_for_service("/get_coordinates", SERVICE_WAIT)
        get_coordinates = rospy.ServiceProxy("/get_coordinates", MyServiceMessage)
        mb.client()                # move_base is up
        start = truth.wait()
        waits.sleep_sim(2.0)          # amcl settles on its first scans
        self.assertLess(start[0], 5.0, "the robot should start in the main hall")
        rows = []
        for label in labels:
            t0 = rospy.Time.now()
            w0 = time.monotonic()
            resp = get_coordinates(label)
            took = (rospy.Time.now() - t0).to_sec()
            wall = time.monotonic() - w0
            waits.sleep_sim(0.5)
            end = truth.pose
            spot = spots[label]
            err_xy, err_yaw = gt.pose_error(end, (spot.x, spot.y, spot.yaw))
            rows.append((label, resp.navigation_successfull, resp.message, took, err_xy, err_yaw))
            print(f"GET_COORDINATES label={label} ok={resp.navigation_successfull} message={resp.message!r} "
                  f"sim_time_s={took:.1f} wall_time_s={wall:.1f} final_xy_error_m={err_xy:.3f} "
                  f"final_yaw_error_rad={err_yaw:.3f} collisions={truth.collisions}", flush=True)
            rospy.loginfo(f"/get_coordinates '{label}': {resp.message} after {took:.1f} s sim "
                          f"({wall:.1f} s wall), error {err_xy:.3f} m, {math.degrees(err_yaw):.1f} deg")
        for label, ok, message, took, err_xy, err_yaw in rows:
            self.assertTrue(ok, f"{label}: {message}")
            self.assertEqual(message, "OK", label)
            self.assertLessEqual(err_xy, xy_tol, f"{label}: {err_xy:.3f} m from the spot")
            self.assertLessEqual(err_yaw, yaw_tol, f"{label}: {err_yaw:.3f} rad off the spot's heading")
        # it crossed rooms: from the hall through the doorway into the fetch room
        self.assertTrue(any(x > 10.5 for _, x, _ in truth.track))
        self.assertEqual(truth.collisions, 0, "the robot collided")


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "get_coordinates_spots", GetCoordinatesSpots, sys.argv)
