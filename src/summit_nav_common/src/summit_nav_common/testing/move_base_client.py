"""move_base from a rostest node or a benchmark: goals, the action client, waiting for a
goal's end, and boxes placed around the robot (the simulator's add_box)."""
import math
import time

import rospy
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import Pose2D
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal

from summit_nav_common.ros.action_client import SimpleActionClient
from summit_nav_common.testing.ground_truth import map_to_world

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
