"""Watching several simulated robots by ground truth (rostests and bench_multi_robot.py).

RobotWatch keeps, for one robot namespace, its true pose (/R/base_pose_ground_truth),
its collision count (/R/collisions, latched), the last move_base result
(/R/move_base/result), the end of its last global plan (/R/<plan_topic>) and the
localization error of /R/amcl_pose against the truth. Closest keeps the smallest distance
between any two watched robots and where two of them passed each other.
"""
import math
import threading
import time

import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
from move_base_msgs.msg import MoveBaseActionResult
from nav_msgs.msg import Odometry, Path
from std_msgs.msg import UInt32
from summit_nav_common.geometry import pose_error, quaternion_to_yaw as yaw_of


class RobotWatch:
    """Ground truth, collisions and move_base's result of robot `name` (thread-safe)."""

    def __init__(self, name, plan_topic="move_base/NavfnROS/plan"):
        self.name = name
        self.lock = threading.Lock()
        self.pose = None             # (x, y, yaw) by ground truth, map frame
        self.path_length = 0.0       # [m] driven, by ground truth
        self.collisions = 0
        self.result = None           # (state, text, stamp [s]) of the last move_base result
        self.loc_error_max = 0.0     # [m] largest amcl_pose error against the ground truth
        self.loc_error = None        # [m] the latest one
        self.plan_end = None         # (x, y) of the last non-empty global plan's last pose
        self.subs = [
            rospy.Subscriber(f"/{name}/base_pose_ground_truth", Odometry, self._on_truth, queue_size=5),
            rospy.Subscriber(f"/{name}/collisions", UInt32, self._on_collisions, queue_size=5),
            rospy.Subscriber(f"/{name}/move_base/result", MoveBaseActionResult, self._on_result, queue_size=5),
            rospy.Subscriber(f"/{name}/amcl_pose", PoseWithCovarianceStamped, self._on_estimate, queue_size=5),
            rospy.Subscriber(f"/{name}/{plan_topic}", Path, self._on_plan, queue_size=5),
        ]

    def _on_truth(self, msg):
        p = msg.pose.pose
        pose = (p.position.x, p.position.y, yaw_of(p.orientation))
        with self.lock:
            if self.pose is not None:
                self.path_length += math.hypot(pose[0] - self.pose[0], pose[1] - self.pose[1])
            self.pose = pose

    def _on_estimate(self, msg):
        p = msg.pose.pose.position
        with self.lock:
            if self.pose is not None:
                self.loc_error = math.hypot(p.x - self.pose[0], p.y - self.pose[1])
                self.loc_error_max = max(self.loc_error_max, self.loc_error)

    def _on_plan(self, msg):
        if msg.poses:
            p = msg.poses[-1].pose.position
            with self.lock:
                self.plan_end = (p.x, p.y)

    def _on_collisions(self, msg):
        with self.lock:
            self.collisions = max(self.collisions, msg.data)

    def _on_result(self, msg):
        with self.lock:
            self.result = (msg.status.status, msg.status.text, msg.header.stamp.to_sec())

    def error_to(self, goal):
        """(xy [m], yaw [rad]) error of the true pose to goal (x, y, yaw [rad])."""
        with self.lock:
            return pose_error(self.pose, goal)

    def close(self):
        for s in self.subs:
            s.unregister()


class Closest:
    """The smallest centre distance [m] between any two watched robots, sampled at `period`
    [s] wall in a thread of its own; and, for the first two, where they passed each other:
    `passed_at` is their two true poses at the first sample where the order of their y
    coordinates is the reverse of the first sample's (None while it is not)."""

    def __init__(self, watches, period=0.05):
        self.watches = watches
        self.min_distance = math.inf
        self.passed_at = None
        self._first_order = None
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, args=(period,), daemon=True)
        self.thread.start()

    def _run(self, period):
        while not self.stop.wait(period):
            poses = [w.pose for w in self.watches if w.pose is not None]
            for i in range(len(poses)):
                for j in range(i + 1, len(poses)):
                    d = math.hypot(poses[i][0] - poses[j][0], poses[i][1] - poses[j][1])
                    self.min_distance = min(self.min_distance, d)
            if len(poses) == len(self.watches) >= 2 and self.passed_at is None:
                order = poses[0][1] > poses[1][1]
                if self._first_order is None:
                    self._first_order = order
                elif order != self._first_order:
                    self.passed_at = (poses[0], poses[1])


def wait_results(watches, timeout_wall, since=0.0, poll=0.1):
    """Wait until every watch has a move_base result stamped after `since` [s sim] or
    timeout_wall [s] passes; returns the names still without one."""
    end = time.monotonic() + timeout_wall
    while time.monotonic() < end and not rospy.is_shutdown():
        missing = [w.name for w in watches if w.result is None or w.result[2] < since]
        if not missing:
            return []
        time.sleep(poll)
    return [w.name for w in watches if w.result is None or w.result[2] < since]
