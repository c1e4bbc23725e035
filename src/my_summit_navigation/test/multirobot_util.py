"""Watching several simulated robots by ground truth (rostests and bench_multi_robot.py).

RobotWatch keeps, for one robot namespace, its true pose (/R/base_pose_ground_truth),
its collision count (/R/collisions, latched), the last move_base result
(/R/move_base/result), the end of its last global plan (/R/<plan_topic>) and the
localization error of /R/amcl_pose against the truth; and, for a look after a failure,
its track: the true pose every TRACK_STEP with the command in force (/R/<cmd_topic>),
a summary of each global plan, and move_base's recoveries and results (format_track
prints the robots' tracks side by side). Closest keeps the smallest distance between any
two watched robots and where two of them passed each other.
"""
import math
import threading
import time

import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from move_base_msgs.msg import MoveBaseActionResult, RecoveryStatus
from nav_msgs.msg import Odometry, Path
from std_msgs.msg import UInt32
from summit_nav_common.geometry import pose_error, quaternion_to_yaw as yaw_of

TRACK_STEP = 0.5      # [s] sim between the track's poses
PLAN_CHANGE = 0.3     # [m] a plan whose length, turning point or end moved less is not listed again


def plan_summary(points):
    """(length [m], start, via, end) of a plan's (x, y) points; via: the point farthest
    from the straight line start -> end (where the route bends away from it)."""
    length = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(points, points[1:]))
    (sx, sy), (ex, ey) = points[0], points[-1]
    chord = math.hypot(ex - sx, ey - sy)

    def off_line(p):
        if chord < 1e-9:
            return math.hypot(p[0] - sx, p[1] - sy)
        return abs((ex - sx) * (p[1] - sy) - (ey - sy) * (p[0] - sx)) / chord
    via = max(points, key=off_line)
    return length, points[0], via, points[-1]


class RobotWatch:
    """Ground truth, collisions and move_base's result of robot `name` (thread-safe)."""

    def __init__(self, name, plan_topic="move_base/NavfnROS/plan", cmd_topic="summit_xl_control/cmd_vel"):
        self.name = name
        self.lock = threading.Lock()
        self.pose = None             # (x, y, yaw) by ground truth, map frame
        self.path_length = 0.0       # [m] driven, by ground truth
        self.collisions = 0
        self.result = None           # (state, text, stamp [s]) of the last move_base result
        self.loc_error_max = 0.0     # [m] largest amcl_pose error against the ground truth
        self.loc_error = None        # [m] the latest one
        self.plan_end = None         # (x, y) of the last non-empty global plan's last pose
        self.track = []              # [(t [s] sim, x, y, yaw, vx [m/s], wz [rad/s])] every TRACK_STEP
        self.plans = []              # [(t [s] sim, plan_summary)] of each non-empty global plan
        self.events = []             # [(t [s] sim, text)] recoveries, results, goals sent
        self._cmd = (0.0, 0.0)       # the last command (vx, wz)
        self.subs = [
            rospy.Subscriber(f"/{name}/base_pose_ground_truth", Odometry, self._on_truth, queue_size=5),
            rospy.Subscriber(f"/{name}/collisions", UInt32, self._on_collisions, queue_size=5),
            rospy.Subscriber(f"/{name}/move_base/result", MoveBaseActionResult, self._on_result, queue_size=5),
            rospy.Subscriber(f"/{name}/amcl_pose", PoseWithCovarianceStamped, self._on_estimate, queue_size=5),
            rospy.Subscriber(f"/{name}/{plan_topic}", Path, self._on_plan, queue_size=5),
            rospy.Subscriber(f"/{name}/{cmd_topic}", Twist, self._on_cmd, queue_size=5),
            rospy.Subscriber(f"/{name}/move_base/recovery_status", RecoveryStatus, self._on_recovery,
                             queue_size=5),
        ]

    def _on_truth(self, msg):
        p = msg.pose.pose
        pose = (p.position.x, p.position.y, yaw_of(p.orientation))
        t = msg.header.stamp.to_sec()
        with self.lock:
            if self.pose is not None:
                self.path_length += math.hypot(pose[0] - self.pose[0], pose[1] - self.pose[1])
            self.pose = pose
            if not self.track or t >= self.track[-1][0] + TRACK_STEP:
                self.track.append((t, *pose, *self._cmd))

    def _on_cmd(self, msg):
        with self.lock:
            self._cmd = (msg.linear.x, msg.angular.z)

    def _on_recovery(self, msg):
        self.note(msg.pose_stamped.header.stamp.to_sec(), f"recovery {msg.current_recovery_number + 1}/"
                  f"{msg.total_number_of_recoveries}: {msg.recovery_behavior_name}")

    def note(self, t, text):
        """An event at t [s] sim for the track."""
        with self.lock:
            self.events.append((t, text))

    def _on_estimate(self, msg):
        p = msg.pose.pose.position
        with self.lock:
            if self.pose is not None:
                self.loc_error = math.hypot(p.x - self.pose[0], p.y - self.pose[1])
                self.loc_error_max = max(self.loc_error_max, self.loc_error)

    def _on_plan(self, msg):
        if msg.poses:
            p = msg.poses[-1].pose.position
            summary = plan_summary([(q.pose.position.x, q.pose.position.y) for q in msg.poses])
            with self.lock:
                self.plan_end = (p.x, p.y)
                self.plans.append((msg.header.stamp.to_sec(), summary))

    def _on_collisions(self, msg):
        with self.lock:
            self.collisions = max(self.collisions, msg.data)

    def _on_result(self, msg):
        with self.lock:
            self.result = (msg.status.status, msg.status.text, msg.header.stamp.to_sec())
            self.events.append((msg.header.stamp.to_sec(), f"result {msg.status.status}: {msg.status.text}"))

    def error_to(self, goal):
        """(xy [m], yaw [rad]) error of the true pose to goal (x, y, yaw [rad])."""
        with self.lock:
            return pose_error(self.pose, goal)

    def close(self):
        for s in self.subs:
            s.unregister()


def _moved(a, b):
    """True when plan summary b differs from a by PLAN_CHANGE or more (length, via or end)."""
    return (abs(a[0] - b[0]) >= PLAN_CHANGE or math.hypot(a[2][0] - b[2][0], a[2][1] - b[2][1]) >= PLAN_CHANGE
            or math.hypot(a[3][0] - b[3][0], a[3][1] - b[3][1]) >= PLAN_CHANGE)


def format_track(watches, step=1.0, since=0.0):
    """The robots' tracks as text, in time order from `since` [s] sim on: one line per
    `step` [s] with each robot's true pose (x, y [m], yaw [rad]) and command (vx [m/s],
    wz [rad/s]) side by side, the first of its samples in that step; between them each
    robot's events and its global plans (length, start, the point where the route bends
    farthest from the straight line, end), a plan only when it differs from the last one
    listed."""
    poses, notes = {}, []
    for i, w in enumerate(watches):
        with w.lock:
            track, plans, events = list(w.track), list(w.plans), list(w.events)
        for t, *sample in track:
            if t >= since:
                poses.setdefault(int(t // step), {}).setdefault(i, sample)
        last = None
        for t, p in plans:
            if t >= since and (last is None or _moved(last, p)):
                notes.append((t, f"{w.name} plan {p[0]:.1f} m ({p[1][0]:.2f}, {p[1][1]:.2f}) via "
                                 f"({p[2][0]:.2f}, {p[2][1]:.2f}) to ({p[3][0]:.2f}, {p[3][1]:.2f})"))
                last = p
        notes += [(t, f"{w.name} {text}") for t, text in events if t >= since]
    blank = " " * 34
    rows = [(k * step, 0, " | ".join(" ".join(f"{v:6.2f}" for v in row[i]) if i in row else blank
                                     for i in range(len(watches))))
            for k, row in poses.items()]
    lines = ["t [s]  " + " | ".join(f"{w.name}: x, y, yaw, vx, wz" for w in watches)]
    for t, kind, text in sorted(rows + [(t, 1, text) for t, text in notes]):
        lines.append(f"{t:6.1f} {text}" if kind == 0 else f"{t:6.2f}   {text}")
    return "\n".join(lines)


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
