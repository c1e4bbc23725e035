#!/usr/bin/python3
"""rostest: several robots, each sent a goal by its send_goal node, all reach it.

The .test starts the simulator and every robot's stack (move_base_multi_robot.launch) and
the send_goal nodes (send_goals.launch, or its own). This node only watches: each robot's
move_base result (/R/move_base/result), its ground truth and its collision counter.

  param ~goals: [{robot: robot_0, x: .., y: .., theta: DEG}, ...] the goals the send_goal
        nodes were given (map frame). A goal with `send_after: {robot: R, y_above: Y}` is
        sent by this node instead, when robot R's true y first exceeds Y (a scenario step
        that must follow another robot's progress, not a time that load can stretch)
  param ~xy_tolerance [m], ~yaw_tolerance [rad]: by ground truth, at the end
  param ~goal_tolerance [m] (optional, 0): how far move_base may move a goal that lies in
        an obstacle's inscribed zone to the nearest free cell (its global planner's
        default_tolerance), as the real navfn does. With it, the xy error is measured to
        where move_base drove, the end of its last global plan (~plan_topic, under the
        robot's namespace), and that end must lie within goal_tolerance + one costmap cell
        (0.05 m) of the goal given
  param ~plan_topic (str, "move_base/NavfnROS/plan")
  param ~result_timeout [s] wall: how long all the results may take (keep it under the
        .test's time-limit)
  param ~boxes (list, optional): [{name: .., x: .., y: .., yaw: DEG, size_x: .., size_y: ..}]
        boxes put into the simulator's world (/summit_xl_sim/add_box, world = map frame)
        at the start, before the send_goal nodes send (give them a ~settle long enough)
  param ~pass_north_of [m] (optional, not checked when absent; two robots): the robots
        must have passed each other (the order of their y swapped) while both were north of
        this y, by ground truth (they met where the scenario has them meet)
  param ~max_path_length [m] (optional, 0 = not checked): no robot may drive farther than
        this by ground truth (no detour around the passage the scenario is about)

Asserts: every move_base result is SUCCEEDED; every robot ends within the tolerances of
its goal by ground truth; zero collisions on every robot (walls, boxes and each other);
with ~pass_north_of, that the robots passed each other there; with ~max_path_length,
that no robot drove farther.
Prints one MULTI_ROBOT line per robot (parsed by bench_multi_robot.py), and on failure
the robots' tracks (multirobot_util.format_track: true poses and commands, global plans,
recoveries, results), also in the failure message, so that a run that failed once can be
read afterwards.
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import Pose2D
from move_base_msgs.msg import MoveBaseAction
from summit_nav_common.ros.action_client import SimpleActionClient
from summit_nav_common.testing.move_base_client import STATE_NAMES

from my_summit_navigation.goals import move_base_goal
from my_summit_navigation.multi_robot import goal_spot

import multirobot_util as mu  # this test's sibling (a rostest node runs from its own folder)

SETTLE = 1.0      # [s] sim: after the last result, before the poses are judged
CELL = 0.05       # [m] the costmaps' resolution: a moved goal lies on a cell centre


def add_boxes(boxes, timeout_wall=60.0):
    """Put each box {name, x, y, yaw [deg], size_x, size_y} into the simulator's world."""
    from summit_xl_sim.srv import AddBox
    rospy.wait_for_service("/summit_xl_sim/add_box", timeout_wall)
    add_box = rospy.ServiceProxy("/summit_xl_sim/add_box", AddBox)
    for b in boxes:
        # in a thread of its own: a simulator stuck in its loop (seen: its ray casting looping
        # forever on a beam along a cell boundary, the clock stopped at 0.05 s) never answers;
        # fail saying so instead of at the .test's time-limit
        answer = []

        def call_add_box(b=b):
            try:
                answer.append(add_box(b["name"], Pose2D(b["x"], b["y"], math.radians(b.get("yaw", 0.0))),
                                      b["size_x"], b["size_y"]))
            except (rospy.ServiceException, rospy.ROSException) as e:
                answer.append(e)
        call = threading.Thread(target=call_add_box, daemon=True)
        call.start()
        call.join(timeout_wall)
        if not answer:
            raise AssertionError(f"add_box {b['name']}: no answer from the simulator within {timeout_wall:.0f} s "
                                 f"(ROS time {rospy.Time.now().to_sec():.2f} s: is its loop stuck?)")
        resp = answer[0]
        if isinstance(resp, Exception):
            raise AssertionError(f"add_box {b['name']}: {resp}")
        if not resp.success:
            raise AssertionError(f"add_box {b['name']}: {resp.message}")
        rospy.loginfo(f"box {b['name']} at ({b['x']:.2f}, {b['y']:.2f}), {b['size_x']:.2f} x {b['size_y']:.2f} m")


def wait_clock(timeout_wall=120.0):
    end = time.monotonic() + timeout_wall
    while rospy.Time.now().is_zero():
        if time.monotonic() > end:
            raise AssertionError(f"no /clock within {timeout_wall:.0f} s")
        time.sleep(0.05)


def send_after(goal, watches, stop, timeout_wall):
    """Send `goal` (a ~goals entry with send_after) to its robot's move_base once the robot
    named in send_after is north of its y_above, by ground truth."""
    after = goal["send_after"]
    lead = next(w for w in watches if w.name == after["robot"])
    client = SimpleActionClient(f"/{goal['robot']}/move_base", MoveBaseAction)
    if not client.wait_for_server(rospy.Duration(timeout_wall)):
        rospy.logerr(f"no /{goal['robot']}/move_base within {timeout_wall:.0f} s")
        return
    while not stop.is_set() and not rospy.is_shutdown():
        with lead.lock:
            y = lead.pose[1] if lead.pose is not None else -math.inf
        if y > after["y_above"]:
            break
        time.sleep(0.02)
    else:
        return
    rospy.loginfo(f"{lead.name} at y {y:.2f} > {after['y_above']}: sending {goal['robot']} its goal")
    spot = goal_spot(goal["x"], goal["y"], goal["theta"])
    now = rospy.Time.now()
    client.send_goal(move_base_goal(spot, "map", now))
    next(w for w in watches if w.name == goal["robot"]).note(
        now.to_sec(), f"goal ({goal['x']:.2f}, {goal['y']:.2f}) sent ({lead.name} at y {y:.2f})")
    stop.wait()   # the client (and its goal handle) lives until the test has judged the run


class MultiRobotGoals(unittest.TestCase):
    def test_every_robot_reaches_its_goal(self):
        rospy.init_node("multi_robot_goals_test")
        goals = rospy.get_param("~goals")
        xy_tol = float(rospy.get_param("~xy_tolerance"))
        yaw_tol = float(rospy.get_param("~yaw_tolerance"))
        timeout = float(rospy.get_param("~result_timeout"))
        goal_tol = float(rospy.get_param("~goal_tolerance", 0.0))
        pass_north_of = rospy.get_param("~pass_north_of", None)
        max_path = float(rospy.get_param("~max_path_length", 0.0))
        add_boxes(rospy.get_param("~boxes", []))
        watches = [mu.RobotWatch(g["robot"], rospy.get_param("~plan_topic", "move_base/NavfnROS/plan"))
                   for g in goals]
        closest = mu.Closest(watches)
        stop = threading.Event()
        for g in goals:
            if "send_after" in g:
                threading.Thread(target=send_after, args=(g, watches, stop, timeout), daemon=True).start()
        wait_clock()
        w0, t0 = time.monotonic(), rospy.Time.now().to_sec()
        missing = mu.wait_results(watches, timeout)
        rospy.sleep(SETTLE)
        closest.stop.set()
        stop.set()
        wall, sim = time.monotonic() - w0, rospy.Time.now().to_sec() - t0
        failures = []
        for g, w in zip(goals, watches):
            goal = (g["x"], g["y"], math.radians(g["theta"]))
            driven_to = goal
            if goal_tol > 0 and w.plan_end is not None:
                moved = math.hypot(w.plan_end[0] - goal[0], w.plan_end[1] - goal[1])
                if moved > goal_tol + CELL:
                    failures.append(f"{w.name}: its last plan ends {moved:.3f} m from its goal "
                                    f"(move_base may move it at most {goal_tol} m + a cell)")
                driven_to = (w.plan_end[0], w.plan_end[1], goal[2])
            err_xy, err_yaw = w.error_to(driven_to) if w.pose is not None else (math.inf, math.inf)
            state, text, stamp = w.result if w.result else (None, "no result", math.nan)
            print(f"MULTI_ROBOT robot={w.name} state={STATE_NAMES.get(state, state)} "
                  f"xy_error_m={err_xy:.3f} yaw_error_rad={err_yaw:.3f} collisions={w.collisions} "
                  f"result_sim_s={stamp - t0:.1f} path_m={w.path_length:.1f} loc_error_max_m={w.loc_error_max:.3f} "
                  f"min_robot_distance_m={closest.min_distance:.2f} "
                  f"goal_moved_m={math.hypot(driven_to[0] - goal[0], driven_to[1] - goal[1]):.3f} "
                  f"text={text!r}", flush=True)
            if w.name in missing:
                failures.append(f"{w.name}: no move_base result within {timeout:.0f} s wall")
            elif state != GoalStatus.SUCCEEDED:
                failures.append(f"{w.name}: move_base ended {STATE_NAMES.get(state, state)}: {text}")
            if err_xy > xy_tol or err_yaw > yaw_tol:
                where = "its goal" if driven_to is goal else "the end of its plan"
                failures.append(f"{w.name}: {err_xy:.3f} m / {err_yaw:.3f} rad from {where} by ground truth "
                                f"(tolerance {xy_tol} m / {yaw_tol} rad)")
            if max_path > 0 and w.path_length > max_path:
                failures.append(f"{w.name}: drove {w.path_length:.1f} m (a detour: at most {max_path} m)")
            if w.collisions:
                failures.append(f"{w.name}: {w.collisions} collisions")
        if pass_north_of is not None:
            passed = closest.passed_at
            if passed is None:
                failures.append("the robots never passed each other")
            elif min(passed[0][1], passed[1][1]) <= pass_north_of:
                failures.append(f"the robots passed each other at y {passed[0][1]:.2f} and {passed[1][1]:.2f}, "
                                f"not both north of y {pass_north_of} (they did not meet there)")
        rospy.loginfo(f"multi-robot goals: {sim:.1f} s sim, {wall:.1f} s wall, closest approach "
                      f"{closest.min_distance:.2f} m, passed each other at {closest.passed_at}")
        if failures:
            track = mu.format_track(watches)
            print(f"MULTI_ROBOT_TRACK\n{track}", flush=True)
            failures.append(f"the tracks:\n{track}")
        self.assertEqual(failures, [], "; ".join(failures))


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "multi_robot_goals", MultiRobotGoals)
