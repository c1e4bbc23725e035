#!/usr/bin/python3
"""rostest: the race track (issue 40), judged by ground truth.

race_track_lap.test (~mode lap): race_track.launch drives one lap. Every waypoint is
reached: at each move_base SUCCEEDED on a waypoint goal the robot is within TOL of it by
ground truth, and auto_navigator's summary says 1 lap, every waypoint reached, nothing
skipped, no dock visit; zero collisions.

race_track_battery.test (~mode battery): the same lap, but once the robot has reached
its second waypoint the battery is set to LOW_SET (/summit_xl_sim/set_battery). Then:
/diagnostics_agg shows the Navigation Stack at WARN with the simulator's battery check
among its children; the cruise cancels, drives to the dock and the simulator reports
CHARGING with the robot within DOCK_TOL of the dock by ground truth; the first waypoint
goal after the charge is the one the low battery interrupted (or the next, when move_base
reported that one reached before the cruise's cancel arrived); the lap is completed with
every waypoint reached, nothing skipped, one dock visit; zero collisions.
"""
import json
import math
import threading
import unittest

import rospy
import rostest
import yaml
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseActionResult
from sensor_msgs.msg import BatteryState
from std_msgs.msg import String

from summit_nav_common.testing import ground_truth as gt, waits

TOL = 0.35        # [m] a reached waypoint by ground truth (xy_goal_tolerance 0.2 + amcl's error)
DOCK_TOL = 0.3    # [m] the simulator charges within this of the dock
LOW_SET = 0.15    # the level the test sets: under the cruise's low_battery (0.2)
GOAL_MATCH = 0.05  # [m] a move_base goal is a waypoint when this close to it
WALL_LIMIT = 1500.0  # [s]


class RaceTrack(unittest.TestCase):
    def setUp(self):
        """Subscribes to move_base's goals and results before waiting for anything: the
        cruise sends its first goal as soon as move_base is up (~0.5 s simulated), and a
        test that subscribed after waiting for the clock and the truth missed it once
        move_base started faster (its kernels compiled at build time instead of numba's
        import): waypoint 0 was never credited."""
        rospy.init_node("race_track_test")
        with open(rospy.get_param("~waypoints_file")) as f:
            route = yaml.safe_load(f)
        self.wps = [(float(w["x"]), float(w["y"])) for w in route["waypoints"]]
        d = route["dock"]
        self.dock = (float(d["x"]), float(d["y"]))
        self.truth = gt.Truth((0.0, 0.0, 0.0))   # the race track's map is its world
        self.lock = threading.Lock()
        self.goals = []          # [(sim t, target: waypoint index or 'dock' or None)]
        self.reached = []        # [(waypoint index, truth error [m])] at each SUCCEEDED
        self.current = None
        self.current_id = None
        self.final = {}          # goal id -> final actionlib status
        self.target_of = {}      # goal id -> its target (a result is matched by its goal's id)
        self.summary = waits.Latest("/auto_navigator/summary", String)
        rospy.Subscriber("/move_base/goal", MoveBaseActionGoal, self.on_goal, queue_size=10)
        rospy.Subscriber("/move_base/result", MoveBaseActionResult, self.on_result, queue_size=10)
        waits.wait_clock()
        self.truth.wait()

    def target(self, xy):
        if math.hypot(xy[0] - self.dock[0], xy[1] - self.dock[1]) < GOAL_MATCH:
            return "dock"
        for i, (x, y) in enumerate(self.wps):
            if math.hypot(xy[0] - x, xy[1] - y) < GOAL_MATCH:
                return i
        return None

    def on_goal(self, msg):
        p = msg.goal.target_pose.pose.position
        with self.lock:
            self.current = self.target((p.x, p.y))
            self.current_id = msg.goal_id.id
            self.target_of[msg.goal_id.id] = self.current
            self.goals.append((rospy.Time.now().to_sec(), self.current))

    def on_result(self, msg):
        with self.lock:
            self.final[msg.status.goal_id.id] = msg.status.status
        if msg.status.status != GoalStatus.SUCCEEDED or self.truth.pose is None:
            return
        with self.lock:
            target = self.target_of.get(msg.status.goal_id.id)
            if isinstance(target, int):
                x, y = self.wps[target]
                self.reached.append((target, math.hypot(self.truth.pose[0] - x, self.truth.pose[1] - y)))

    def wait_summary(self):
        """The summary, once every goal seen has its result here too.

        The cruise publishes its summary right after the last goal's result, but on
        another topic and connection: in CI's run of 2026-11-28 (race_track_battery) the
        summary reached this test before the last waypoint's SUCCEEDED, and the lap
        looked one waypoint short (12 of 13).
        """
        waits.wait_for(lambda: self.summary.msg is not None, "/auto_navigator/summary", WALL_LIMIT)

        def all_final():
            with self.lock:
                return all(gid in self.final for gid in self.target_of)
        waits.wait_for(all_final, "a result for every goal sent", 30.0)
        return json.loads(self.summary.msg.data)

    def check_lap(self, summary, dock_visits):
        n = len(self.wps)
        self.assertEqual(summary["laps"], 1, summary)
        self.assertEqual(summary["reached"], n, summary)
        self.assertEqual(summary["skipped"], [], summary)
        self.assertEqual(summary["dock_visits"], dock_visits, summary)
        with self.lock:
            reached = list(self.reached)
        self.assertEqual(sorted({i for i, _ in reached}), list(range(n)), reached)
        far = [(i, round(e, 2)) for i, e in reached if e > TOL]
        self.assertEqual(far, [], f"waypoints reported reached farther than {TOL} m by ground truth")
        self.assertEqual(self.truth.collisions, 0, "collisions")

    def test_race_track(self):
        mode = rospy.get_param("~mode", "lap")
        if mode == "lap":
            self.check_lap(self.wait_summary(), dock_visits=0)
            return
        self.assertEqual(mode, "battery")
        from summit_xl_sim.srv import SetBattery
        battery = waits.Latest("/battery_state", BatteryState)
        agg = waits.Latest("/diagnostics_agg", DiagnosticArray)
        rospy.wait_for_service("/summit_xl_sim/set_battery", 60.0)
        set_battery = rospy.ServiceProxy("/summit_xl_sim/set_battery", SetBattery)
        waits.wait_for(lambda: len({i for i, _ in self.reached}) >= 2, "two waypoints reached", WALL_LIMIT)
        with self.lock:
            interrupted, interrupted_id = self.current, self.current_id
        self.assertIsInstance(interrupted, int, "the goal active when the battery was set low")
        resp = set_battery(percentage=LOW_SET)
        self.assertTrue(resp.success, resp.message)

        def stack_warns():
            msg = agg.msg
            if msg is None:
                return False
            levels = {s.name: s.level for s in msg.status}
            top = levels.get("/Navigation Stack")
            bat = [lv for name, lv in levels.items() if name.startswith("/Navigation Stack/") and "Battery" in name]
            return top is not None and top >= DiagnosticStatus.WARN and any(lv >= DiagnosticStatus.WARN for lv in bat)
        waits.wait_for(stack_warns, "/diagnostics_agg: Navigation Stack at WARN with its battery check", 120.0)

        charged_at = {}

        def charging_at_dock():
            msg = battery.msg
            if msg is None or msg.power_supply_status != BatteryState.POWER_SUPPLY_STATUS_CHARGING:
                return False
            x, y, _ = self.truth.pose
            charged_at["d"] = math.hypot(x - self.dock[0], y - self.dock[1])
            charged_at["t"] = rospy.Time.now().to_sec()
            return True
        waits.wait_for(charging_at_dock, "the robot charging at the dock", WALL_LIMIT)
        self.assertLessEqual(charged_at["d"], DOCK_TOL, "charging, by ground truth this far from the dock")
        summary = self.wait_summary()
        with self.lock:
            after = [g for t, g in self.goals if t > charged_at["t"] and g != "dock"]
            docks = [g for _, g in self.goals if g == "dock"]
        self.assertTrue(docks, "no goal was sent to the dock")
        self.assertTrue(after, "no waypoint goal after the charge")
        with self.lock:
            reached_first = self.final.get(interrupted_id) == GoalStatus.SUCCEEDED
        # A waypoint move_base reached while the low battery's cancel was on its way is
        # done: the cruise then resumes at the next one.
        expected = (interrupted + 1) % len(self.wps) if reached_first else interrupted
        self.assertEqual(after[0], expected, "the cruise resumed at another waypoint than the interrupted one")
        self.check_lap(summary, dock_visits=1)


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "race_track", RaceTrack)
