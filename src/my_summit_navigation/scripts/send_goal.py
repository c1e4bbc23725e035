#!/usr/bin/python3
"""send_goal: send one robot of several a goal, as in the course's multi-robot lesson.

    rosrun my_summit_navigation send_goal.py ROBOT _goal_x:=X _goal_y:=Y _goal_theta:=DEG
    roslaunch my_summit_navigation send_goals.launch        # the lesson's two goals

ROBOT is the robot's id: its namespace, robot_N (or just N). The goal is the pose
(goal_x [m], goal_y [m], goal_theta [deg]) in ~frame_id (default map), sent through an
actionlib SimpleActionClient to /ROBOT/move_base (move_base_msgs/MoveBaseAction). The
outcome is logged with the robot's name: reached, or why not (aborted with move_base's
reason, e.g. a goal off the map or in a wall; no such robot; no move_base for it).

  param ~goal_x [m], ~goal_y [m], ~goal_theta [deg] (float, required): the goal
  param ~frame_id (str, "map"): the goal's frame
  param ~server_timeout (float [s], 30.0): how long to wait for the robot's move_base
  param ~goal_timeout (float [s] ROS time, 0 = none): cancel the goal when not done by then
  param ~settle (float [s] ROS time, 2.0): before sending, wait for the robot's first
        /ROBOT/amcl_pose (amcl or fake_localization running) and then this long, so that
        a launch started together with the stack does not send the goal before the
        costmaps hold a scan (the other robots in them)

Exit code: 0 the goal was reached; 1 it was not (aborted, preempted, timed out, no such
robot or no move_base); 2 bad arguments or parameters (nothing sent).
"""
import sys

import rosgraph
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
from move_base_msgs.msg import MoveBaseAction
from summit_nav_common.ros.action_client import SimpleActionClient

from my_summit_navigation import spot_goals as sg
from my_summit_navigation.goals import move_base_goal, wait_clock
from my_summit_navigation.multi_robot import GoalError, goal_spot, robot_namespace

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
POLL = 0.1            # [s] ROS time: how often the outcome is looked at
FEEDBACK_PERIOD = 5.0  # [s] ROS time between progress lines (debug level)


def why_no_server(robot, action):
    """Why /ROBOT/move_base is not there: no such robot namespace, or no move_base in it."""
    try:
        publishers, _, _ = rosgraph.Master(rospy.get_name()).getSystemState()
    except Exception as e:  # noqa: BLE001 - the master went away: say so
        return f"the ROS master cannot be asked for topics ({e})"
    me = rospy.get_name()
    # topics someone else publishes (this node's own action client publishes /ROBOT/move_base/goal)
    topics = [t for t, nodes in publishers if any(n != me for n in nodes)]
    robots = sorted({t.split("/")[1] for t in topics if t.endswith("/move_base/status") and t.count("/") == 3})
    known = f"robots with a move_base: {', '.join(robots) if robots else 'none'}"
    if not any(t.startswith(f"/{robot}/") for t in topics):
        return f"no robot '{robot}': nothing is published under /{robot}/ ({known})"
    return f"robot '{robot}' has no move_base action server {action} ({known})"


def main(argv):
    rospy.init_node("send_goal", anonymous=True)
    if len(argv) != 1:
        rospy.logerr(f"send_goal: expected one argument, the robot id (robot_N or N), got {argv}")
        return EXIT_USAGE
    try:
        robot = robot_namespace(argv[0])
        spot = goal_spot(rospy.get_param("~goal_x", None), rospy.get_param("~goal_y", None),
                         rospy.get_param("~goal_theta", None))
    except GoalError as e:
        rospy.logerr(f"send_goal {argv[0]}: {e}; nothing sent")
        return EXIT_USAGE
    frame_id = rospy.get_param("~frame_id", "map")
    server_timeout = float(rospy.get_param("~server_timeout", 30.0))
    goal_timeout = float(rospy.get_param("~goal_timeout", 0.0))
    action = f"/{robot}/move_base"
    what = f"{robot}: goal ({spot.x:.2f}, {spot.y:.2f}) m, {rospy.get_param('~goal_theta')} deg in {frame_id}"

    client = SimpleActionClient(action, MoveBaseAction)
    if not wait_clock(server_timeout) or not client.wait_for_server(rospy.Duration(server_timeout)):
        reason = why_no_server(robot, action) if not rospy.Time.now().is_zero() else \
            "no /clock (is the simulator running?)"
        rospy.logerr(f"send_goal {what}: not sent: {reason} after {server_timeout:g} s")
        return EXIT_FAILED
    settle = float(rospy.get_param("~settle", 2.0))
    if settle > 0:
        try:
            rospy.wait_for_message(f"/{robot}/amcl_pose", PoseWithCovarianceStamped, timeout=server_timeout)
        except rospy.ROSException:
            rospy.logwarn(f"send_goal {what}: no /{robot}/amcl_pose within {server_timeout:g} s; sending anyway")
        rospy.sleep(settle)
    rospy.loginfo(f"send_goal {what}: sent to {action}")
    t0 = rospy.Time.now()
    last = [t0]

    def on_feedback(fb):
        now = rospy.Time.now()
        if (now - last[0]).to_sec() >= FEEDBACK_PERIOD:
            last[0] = now
            p = fb.base_position.pose.position
            rospy.logdebug(f"send_goal {robot}: at ({p.x:.2f}, {p.y:.2f})")

    client.send_goal(move_base_goal(spot, frame_id, t0), feedback_cb=on_feedback)
    deadline = t0 + rospy.Duration(goal_timeout) if goal_timeout > 0 else None
    while not client.wait_for_result(rospy.Duration(POLL)):
        if rospy.is_shutdown():
            client.cancel_goal()
            rospy.logwarn(f"send_goal {what}: shut down; goal canceled")
            return EXIT_FAILED
        if deadline is not None and rospy.Time.now() > deadline:
            client.cancel_goal()
            rospy.logerr(f"send_goal {what}: not reached within {goal_timeout:g} s; goal canceled")
            return EXIT_FAILED
    state = client.get_state()
    ok, message = sg.answer_for_state(state, client.get_goal_status_text())
    took = (rospy.Time.now() - t0).to_sec()
    if ok:
        rospy.loginfo(f"send_goal {what}: reached after {took:.1f} s")
        return EXIT_OK
    rospy.logerr(f"send_goal {what}: NOT reached after {took:.1f} s: {message}")
    return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main(rospy.myargv(sys.argv)[1:]))
