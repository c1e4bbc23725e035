"""Helpers for the move_base rostest nodes: goals, the action client, ground truth.

Ground truth comes from the simulator in the world frame and is taken into the map
frame of the committed map with my_summit_localization's loctest_util (map_in_world:
the spawn pose refined by registering the map against the world).
"""
import math
import os
import sys
import threading
import time

import rospkg
import rospy
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import Pose2D
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import Odometry
from std_msgs.msg import UInt32
from summit_nav_common.ros.action_client import SimpleActionClient

sys.path.insert(0, os.path.join(rospkg.RosPack().get_path("my_summit_localization"), "test"))
import loctest_util as lu  # noqa: E402,F401  (re-exported: Latest, wait_for, map_in_world, ...)

STATE_NAMES = {v: k for k, v in GoalStatus.__dict__.items() if isinstance(v, int) and k.isupper()}
SERVER_WAIT = 120.0   # [s] wall: the whole stack may take a while to come up under load


def make_goal(x, y, yaw=0.0, frame="map", q=None):
    """MoveBaseGoal at (x [m], y [m], yaw [rad]) in frame; q (x, y, z, w) overrides yaw."""
    g = MoveBaseGoal()
    g.target_pose.header.frame_id = frame
    g.target_pose.header.stamp = rospy.Time.now()
    g.target_pose.pose.position.x, g.target_pose.pose.position.y = x, y
    o = g.target_pose.pose.orientation
    if q is None:
        q = (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))
    o.x, o.y, o.z, o.w = q
    return g


def client(name="move_base"):
    """A SimpleActionClient connected to move_base (AssertionError when it does not come up)."""
    c = SimpleActionClient(name, MoveBaseAction)
    if not c.wait_for_server(rospy.Duration(0)) and not _wait_server(c):
        raise AssertionError(f"no action server {name} within {SERVER_WAIT} s")
    return c


def _wait_server(c):
    end = time.monotonic() + SERVER_WAIT
    while time.monotonic() < end and not rospy.is_shutdown():
        if c.wait_for_server(rospy.Duration(1.0)):
            return True
    return False


def wait_result(c, timeout_sim, timeout_wall=400.0):
    """Wait for the client's goal to end (sim and wall bounds); returns (state name, text)."""
    t_end = rospy.Time.now() + rospy.Duration(timeout_sim)
    w_end = time.monotonic() + timeout_wall
    while not rospy.is_shutdown():
        if c.wait_for_result(rospy.Duration(0.5)):
            return STATE_NAMES.get(c.get_state(), c.get_state()), c.get_goal_status_text()
        if rospy.Time.now() > t_end or time.monotonic() > w_end:
            raise AssertionError(f"the goal did not end within {timeout_sim} s sim / {timeout_wall} s wall "
                                 f"(state {STATE_NAMES.get(c.get_state())})")
    raise AssertionError("shut down while waiting for the goal")


def state_name(c):
    return STATE_NAMES.get(c.get_state(), c.get_state())


class Truth:
    """Ground truth (in the map frame), the collision count and the driven track."""

    def __init__(self, m_in_w):
        self.m_in_w = m_in_w
        self.lock = threading.Lock()
        self.pose = None           # (x, y, yaw) map frame
        self.track = []            # [(t, x, y)] map frame
        self.collisions = 0
        self.coll_msgs = 0
        rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on_truth, queue_size=20)
        rospy.Subscriber("/collisions", UInt32, self._on_coll, queue_size=5)

    def _on_truth(self, msg):
        p = lu.truth_in_map(msg, self.m_in_w)
        with self.lock:
            self.pose = p
            if not self.track or math.hypot(p[0] - self.track[-1][1], p[1] - self.track[-1][2]) > 0.02:
                self.track.append((msg.header.stamp.to_sec(), p[0], p[1]))

    def _on_coll(self, msg):
        with self.lock:
            self.collisions = max(self.collisions, msg.data)
            self.coll_msgs += 1

    def wait(self):
        lu.wait_for(lambda: self.pose is not None, "ground truth on /base_pose_ground_truth")
        return self.pose


def world_to_map(m_in_w, x, y):
    """A world point (x, y) [m] in the map frame."""
    p = lu.compose(lu.inverse(m_in_w), (x, y, 0.0))
    return p[0], p[1]


def map_to_world(m_in_w, x, y):
    """A map-frame point (x, y) [m] in the world frame."""
    p = lu.compose(m_in_w, (x, y, 0.0))
    return p[0], p[1]


def ring_robot(add_box, pose, m_in_w, inner, wall):
    """Four boxes (the simulator's add_box) around the robot at pose (map frame): room to
    turn in place (inner [m] from its centre to each wall) but no gap to leave by.
    Returns the boxes' names."""
    wx, wy = map_to_world(m_in_w, pose[0], pose[1])
    wyaw = pose[2] + m_in_w[2]
    off = inner + wall / 2.0
    length = 2.0 * (inner + wall)    # long enough to close the corners
    names = []
    for name, (dx, dy, along) in {"ring_front": (off, 0.0, False), "ring_back": (-off, 0.0, False),
                                  "ring_left": (0.0, off, True), "ring_right": (0.0, -off, True)}.items():
        cx = wx + dx * math.cos(wyaw) - dy * math.sin(wyaw)
        cy = wy + dx * math.sin(wyaw) + dy * math.cos(wyaw)
        sx, sy = (length, wall) if along else (wall, length)
        resp = add_box(name, Pose2D(cx, cy, wyaw), sx, sy)
        if not resp.success:
            raise RuntimeError(f"add_box {name}: {resp.message}")
        names.append(name)
    return names
