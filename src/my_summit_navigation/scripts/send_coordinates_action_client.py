#!/usr/bin/python3
"""send_coordinates_action_client: send one goal to move_base from the command line.

    rosrun my_summit_navigation send_coordinates_action_client.py LABEL [options]
    rosrun my_summit_navigation send_coordinates_action_client.py X Y YAW [options]

LABEL is looked up in the spots file (--spots-file, default my_summit_localization's
config/spots.yaml; the spot recorder's spots.txt reads just as well); X Y [m] and YAW
[rad] are a pose in --frame (default map). The goal goes to the move_base action
(move_base_msgs/MoveBaseAction) through an actionlib SimpleActionClient; the robot's
position from the action's feedback is printed every --feedback-period seconds, then the
outcome (state and move_base's text). Ctrl-C cancels the goal.

Exit code: 0 the goal succeeded; 1 it did not (aborted, preempted, timed out, no
move_base); 2 bad arguments or an unusable spots file (nothing sent).
"""
import argparse
import math
import sys

import rospkg
import rospy
from my_summit_navigation.goals import move_base_goal, wait_clock
from move_base_msgs.msg import MoveBaseAction
from summit_nav_common.ros.action_client import SimpleActionClient

from my_summit_navigation import spot_goals as sg

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
POLL = 0.1            # [s] ROS time: how often the outcome is looked at
CANCEL_FLUSH = 0.3    # [s] wall: time for the cancel message to go out before exiting


def parse_args(argv):
    default_spots = rospkg.RosPack().get_path("my_summit_localization") + "/config/spots.yaml"
    p = argparse.ArgumentParser(prog="send_coordinates_action_client.py",
                                description="Send one goal to move_base: a spot's label or x y yaw.")
    p.add_argument("target", nargs="+", metavar="LABEL | X Y YAW",
                   help="a label of the spots file, or x [m] y [m] yaw [rad]")
    p.add_argument("--spots-file", default=default_spots, help="spots file for a label (default %(default)s)")
    p.add_argument("--frame", default="map", help="frame of x y yaw (default %(default)s)")
    p.add_argument("--action", default="move_base", help="move_base action name (default %(default)s)")
    p.add_argument("--server-timeout", type=float, default=30.0,
                   help="[s] wait for the action server (default %(default)s)")
    p.add_argument("--timeout", type=float, default=0.0,
                   help="[s] ROS time: cancel the goal after this long; 0 = wait (default)")
    p.add_argument("--feedback-period", type=float, default=1.0,
                   help="[s] ROS time between printed feedback lines (default %(default)s)")
    return p.parse_args(argv)


def resolve_target(args):
    """(label, Spot, frame_id) of the command line; sg.UsageError / SpotsError say why not."""
    kind, value = sg.parse_target(args.target)
    if kind == "pose":
        return f"{value.x:g} {value.y:g} {value.yaw:g}", value, args.frame
    book = sg.SpotBook(args.spots_file)
    book.refresh()
    spot, frame_id, refusal = book.lookup(value)
    if refusal is not None:
        raise sg.UsageError(refusal)
    return value, spot, frame_id


def make_goal(spot, frame_id):
    return move_base_goal(spot, frame_id, rospy.Time.now())


def main(argv):
    args = parse_args(argv)
    try:
        label, spot, frame_id = resolve_target(args)
    except sg.UsageError as e:
        print(f"send_coordinates_action_client: {e}", file=sys.stderr)
        return EXIT_USAGE
    # Ctrl-C raises KeyboardInterrupt here (not a rospy shutdown) so the goal can still be canceled
    rospy.init_node("send_coordinates_action_client", anonymous=True, disable_signals=True)
    client = SimpleActionClient(args.action, MoveBaseAction)
    print(f"waiting for move_base ({rospy.resolve_name(args.action)}) ...", flush=True)
    if not wait_clock(args.server_timeout) or not client.wait_for_server(rospy.Duration(args.server_timeout)):
        print(sg.answer_no_server(rospy.resolve_name(args.action), args.server_timeout), flush=True)
        return EXIT_FAILED
    last = [None]

    def on_feedback(fb):
        now = rospy.Time.now()
        if last[0] is not None and (now - last[0]).to_sec() < args.feedback_period:
            return
        last[0] = now
        p = fb.base_position.pose.position
        print(f"feedback: robot at x {p.x:.2f} m, y {p.y:.2f} m; {math.hypot(spot.x - p.x, spot.y - p.y):.2f} m "
              f"to the goal", flush=True)

    print(f"goal: {sg.describe(label, spot, frame_id)}", flush=True)
    t0 = rospy.Time.now()
    client.send_goal(make_goal(spot, frame_id), feedback_cb=on_feedback)
    deadline = t0 + rospy.Duration(args.timeout) if args.timeout > 0 else None
    try:
        while not client.wait_for_result(rospy.Duration(POLL)):
            if rospy.is_shutdown():
                raise KeyboardInterrupt
            if deadline is not None and rospy.Time.now() > deadline:
                client.cancel_goal()
                rospy.rostime.wallsleep(CANCEL_FLUSH)
                print(sg.answer_goal_timeout(label, args.timeout), flush=True)
                return EXIT_FAILED
    except KeyboardInterrupt:
        client.cancel_goal()
        rospy.rostime.wallsleep(CANCEL_FLUSH)
        print("interrupted: the goal was canceled", flush=True)
        return EXIT_FAILED
    state = client.get_state()
    ok, message = sg.answer_for_state(state, client.get_goal_status_text())
    took = (rospy.Time.now() - t0).to_sec()
    print(f"result: {sg.STATE_NAMES.get(state, state)} after {took:.1f} s: "
          f"{client.get_goal_status_text() if ok else message}", flush=True)
    return EXIT_OK if ok else EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main(rospy.myargv(sys.argv)[1:]))
