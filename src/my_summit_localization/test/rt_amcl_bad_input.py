#!/usr/bin/python3
"""rostest: bad input to amcl and /save_spot before localization.

Launch: the simulator, amcl with use_map_topic and *no* map server, spot_recorder. The
test: amcl says it waits for the map; /save_spot refuses a label before amcl has a pose,
an empty label, and `end` with no spot (no file written); then the test publishes the
committed map late and amcl localizes; an initialpose in another frame, with NaN, or with
a bad covariance is ignored with a warning; one with an empty frame is taken (warning);
set_map refuses a map whose data does not fit its size and takes a good one with its pose.
Last, amcl keeps its pose: it is saved as ~initial_pose_* and a restarted amcl (killed,
respawned by roslaunch) resumes there rather than at the launch file's initial pose.
"""
import math
import os
import sys
import unittest

import rosgraph
import rosnode
import rospy
import rostest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.srv import SetMap
from std_srvs.srv import Empty
from summit_nav_common.map_io import load_map

from my_summit_localization.srv import MyServiceMessage
from summit_nav_common.ros.map_msgs import grid_to_msg

from summit_nav_common.geometry import quaternion_to_yaw as yaw_of
from summit_nav_common.testing.ground_truth import map_in_world, pose_error, truth_in_map
from summit_nav_common.testing.waits import Latest, RosoutWatcher, sleep_sim, wait_clock, wait_for

POS_TOL = 0.15             # [m] amcl vs ground truth while nothing disturbs it
YAW_TOL = math.radians(5)  # [rad]


def initialpose_msg(frame, x, y, yaw, cov=(0.05, 0.05, 0.02)):
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = frame
    msg.header.stamp = rospy.Time.now()
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    c = [0.0] * 36
    c[0], c[7], c[35] = cov
    msg.pose.covariance = c
    return msg


class AmclBadInput(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("amcl_bad_input_test")
        cls.log = RosoutWatcher()
        cls.truth = Latest("/base_pose_ground_truth", Odometry)
        cls.amcl_pose = Latest("/amcl_pose", PoseWithCovarianceStamped)
        cls.init_pub = rospy.Publisher("/initialpose", PoseWithCovarianceStamped, queue_size=5)
        cls.map_pub = rospy.Publisher("/map", OccupancyGrid, queue_size=1, latch=True)
        rospy.wait_for_service("/save_spot", 60.0)
        cls.save_spot = rospy.ServiceProxy("/save_spot", MyServiceMessage)
        cls.nomotion = rospy.ServiceProxy("/request_nomotion_update", Empty)
        cls.spots_file = rospy.get_param("/spot_recorder/spots_file")
        if os.path.exists(cls.spots_file):
            os.unlink(cls.spots_file)
        cls.m_in_w = map_in_world()
        wait_clock()
        cls.truth.wait()

    def amcl_error(self):
        """(position, yaw) error of the latest amcl_pose against ground truth."""
        p = self.amcl_pose.msg.pose.pose
        est = (p.position.x, p.position.y, yaw_of(p.orientation))
        return pose_error(est, truth_in_map(self.truth.msg, self.m_in_w))

    def fresh_pose(self, since=None, tries=5):
        """Force an update without motion and wait for the amcl_pose it produces; with
        since (a time), for one stamped at or after it.

        amcl publishes outside its lock, so an update computed just before a new pose or
        map can be published after it: one repeat run (session 28) took such a pose, from
        the filter set_map had replaced, for the answer to the no-motion request."""
        for _ in range(tries):
            n = self.amcl_pose.count
            self.nomotion()
            self.amcl_pose.wait(30.0, after=n)
            if since is None or self.amcl_pose.msg.header.stamp >= since:
                return
        self.fail(f"no amcl_pose stamped after {since.to_sec():.2f} in {tries} no-motion updates")

    def settle(self, max_updates=8, cov_xx=0.05):
        """Request no-motion updates until amcl_pose's cov_xx is below `cov_xx`.

        Augmented MCL (recovery_alpha_slow/fast on in the course config) injects random
        particles whenever a scan scores below the running average, also right after an
        initialpose, as amcl does; amcl's covariance is the whole set's, so five random
        particles of 5000 make cov_xx 0.37. One repeat run of 16 (session 27): the
        second update after the initialpose 0.6 m off scored 0.690 against 0.697, 0.1 %
        were injected, and the pose amcl saved had cov_xx 0.47. The next resamplings
        drop them."""
        for _ in range(max_updates):
            if self.amcl_pose.msg.pose.covariance[0] < cov_xx:
                return
            self.fresh_pose()
        self.fail(f"amcl_pose cov_xx still {self.amcl_pose.msg.pose.covariance[0]:.3f} after "
                  f"{max_updates} no-motion updates")

    def wait_saved(self, periods=3):
        """Wait until amcl has saved the pose it last published, with its small covariance,
        within `periods` save periods of simulated time; returns the saved (x, y, cov_xx).

        amcl writes its six ~initial_* parameters one call at a time (as the real one's
        savePoseToServer), so the test reads the /amcl namespace in one call and waits
        for a complete save: one CI run (load 9) read the new x and y and the previous
        save's initial_cov_xx 0.29 while a save was half written. The pose compared is
        the latest amcl_pose at each look, not one taken before: after an initialpose amcl
        updates on the next scan and again on the no-motion request, and one CI run
        (fresh clone of 00ae3aa) took the first of the two, (0.526, -0.025), while amcl
        saved the second, (0.505, -0.029), 2.1 cm away."""
        period = 1.0 / rospy.get_param("/amcl/save_pose_rate")
        deadline = rospy.Time.now() + rospy.Duration(periods * period)
        while True:
            p = rospy.get_param("/amcl")
            saved = (p["initial_pose_x"], p["initial_pose_y"], p["initial_cov_xx"])
            last = self.amcl_pose.msg.pose.pose.position
            if abs(saved[0] - last.x) <= 0.02 and abs(saved[1] - last.y) <= 0.02 and saved[2] < 0.05:
                return saved
            if rospy.Time.now() > deadline:
                self.fail(f"amcl did not save the pose it published last ({last.x:.3f}, {last.y:.3f}) with "
                          f"cov_xx < 0.05 within {periods * period:.0f} s: saved {saved}")
            sleep_sim(0.1)

    def test_1_late_map_and_spots_before_a_pose(self):
        self.log.wait("amcl", "waiting for the map")
        sleep_sim(2.0)
        self.assertEqual(self.amcl_pose.count, 0, "amcl published a pose without a map")
        r = self.save_spot("room")
        self.assertFalse(r.navigation_successfull)
        self.assertIn("no pose yet", r.message)
        r = self.save_spot("")
        self.assertFalse(r.navigation_successfull)
        self.assertIn("label is empty", r.message)
        r = self.save_spot("end")
        self.assertFalse(r.navigation_successfull)
        self.assertIn("no spot stored", r.message)
        self.assertFalse(os.path.exists(self.spots_file), "end with no spot wrote a file")
        # the map arrives late: amcl takes it and localizes at the initial pose
        grid = load_map(rospy.get_param("~map_file"))
        self.map_pub.publish(grid_to_msg(grid, "map", stamp=rospy.Time.now()))
        self.log.wait("amcl", "received a")
        self.amcl_pose.wait(60.0)
        self.fresh_pose()
        e_pos, e_yaw = self.amcl_error()
        self.assertLess(e_pos, POS_TOL)
        self.assertLess(e_yaw, YAW_TOL)
        r = self.save_spot("room")
        self.assertTrue(r.navigation_successfull, r.message)

    def test_2_initialpose_in_another_frame_is_ignored(self):
        self.amcl_pose.wait(60.0)
        mark = self.log.mark()
        self.init_pub.publish(initialpose_msg("odom", 5.0, 5.0, 1.0))
        self.log.wait("amcl", "frame 'odom' ignored", mark)
        self.fresh_pose()
        self.assertLess(self.amcl_error()[0], POS_TOL)

    def test_3_initialpose_with_nan_is_ignored(self):
        self.amcl_pose.wait(60.0)
        mark = self.log.mark()
        self.init_pub.publish(initialpose_msg("map", float("nan"), 5.0, 1.0))
        self.log.wait("amcl", "NaN", mark)
        mark = self.log.mark()
        self.init_pub.publish(initialpose_msg("map", 5.0, 5.0, 1.0, cov=(-0.1, 0.05, 0.02)))
        self.log.wait("amcl", "positive semi-definite", mark)
        self.fresh_pose()
        self.assertLess(self.amcl_error()[0], POS_TOL)

    def test_4_initialpose_empty_frame_is_taken_with_a_warning(self):
        self.amcl_pose.wait(60.0)
        truth = truth_in_map(self.truth.msg, self.m_in_w)
        mark = self.log.mark()
        # 0.3 m off the truth, small spread: amcl must move there (and then refine)
        self.init_pub.publish(initialpose_msg("", truth[0] + 0.3, truth[1], truth[2],
                                              cov=(0.0025, 0.0025, 0.001)))
        self.log.wait("amcl", "empty frame_id", mark)
        self.log.wait("amcl", "initial pose set", mark)
        self.fresh_pose(since=rospy.Time.now())
        p = self.amcl_pose.msg.pose.pose.position
        self.assertGreater(math.hypot(p.x - truth[0], p.y - truth[1]), 0.1,
                           "amcl did not take the initialpose with an empty frame_id")
        # put it back for good measure
        self.init_pub.publish(initialpose_msg("map", *truth))
        sleep_sim(0.5)
        self.fresh_pose()
        self.assertLess(self.amcl_error()[0], POS_TOL)

    def test_4b_set_map(self):
        """set_map (nav_msgs/SetMap, amcl's since Indigo; ours lacked it): a map whose data
        does not fit its size is refused (success false, amcl keeps its pose); the
        committed map with an initial pose 0.3 m off the truth restarts the filter there;
        again with the truth brings it back."""
        self.amcl_pose.wait(60.0)
        rospy.wait_for_service("/set_map", 30.0)
        set_map = rospy.ServiceProxy("/set_map", SetMap)
        grid = load_map(rospy.get_param("~map_file"))
        truth = truth_in_map(self.truth.msg, self.m_in_w)
        bad = grid_to_msg(grid, "map", stamp=rospy.Time.now())
        bad.info.width += 1
        mark = self.log.mark()
        self.assertFalse(set_map(bad, initialpose_msg("map", *truth)).success)
        self.log.wait("amcl", "map ignored", mark)
        self.fresh_pose()
        self.assertLess(self.amcl_error()[0], POS_TOL)
        good = grid_to_msg(grid, "map", stamp=rospy.Time.now())
        mark = self.log.mark()
        self.assertTrue(set_map(good, initialpose_msg("map", truth[0] + 0.3, truth[1], truth[2],
                                                      cov=(0.0025, 0.0025, 0.001))).success)
        self.log.wait("amcl", "initial pose set", mark)
        self.fresh_pose(since=rospy.Time.now())
        p = self.amcl_pose.msg.pose.pose.position
        self.assertGreater(math.hypot(p.x - truth[0], p.y - truth[1]), 0.1, "set_map's initial pose not taken")
        self.assertTrue(set_map(good, initialpose_msg("map", *truth)).success)
        self.fresh_pose(since=rospy.Time.now())
        self.assertLess(self.amcl_error()[0], POS_TOL)

    def test_5_restart_resumes_at_the_saved_pose(self):
        self.amcl_pose.wait(60.0)
        truth = truth_in_map(self.truth.msg, self.m_in_w)
        # 0.6 m off the truth with a 2 cm spread: far from the launch's initial pose (0, 0)
        mark = self.log.mark()
        self.init_pub.publish(initialpose_msg("map", truth[0] + 0.6, truth[1], truth[2],
                                              cov=(0.0004, 0.0004, 0.0004)))
        self.log.wait("amcl", "initial pose set", mark)
        self.fresh_pose()
        self.settle()
        saved = self.wait_saved()
        self.assertGreater(saved[0] - truth[0], 0.3)
        # The respawned amcl is told apart by its new XML-RPC URI. Its first log lines are
        # no proof: /rosout drops what a new node logs before rosout has connected to it
        # (one CI run missed its "received a ... map" line).
        master = rosgraph.Master(rospy.get_name())
        old_uri = rosnode.get_api_uri(master, "/amcl", skip_cache=True)
        rosnode.kill_nodes(["/amcl"])
        wait_for(lambda: rosnode.get_api_uri(master, "/amcl", skip_cache=True) not in (None, old_uri),
                 "respawned /amcl registered")
        n = self.amcl_pose.count
        self.amcl_pose.wait(60.0, after=n)
        p = self.amcl_pose.msg.pose.pose.position
        self.assertLess(math.hypot(p.x - saved[0], p.y - saved[1]), 0.15,
                        "the restarted amcl did not resume at the saved pose")

if __name__ == "__main__":
    rostest.rosrun("my_summit_localization", "amcl_bad_input", AmclBadInput, sys.argv)
