#!/usr/bin/python3
"""get_coordinates_service_server: the course's /get_coordinates service (a thin adapter).

    rosrun my_summit_navigation get_coordinates_service_server.py [_spots_file:=PATH]
    rosservice call /get_coordinates "label: 'room'"

  srv   get_coordinates (my_summit_navigation/MyServiceMessage): label in; the robot is
        driven to the spot saved under it; navigation_successfull true and message "OK"
        when move_base reached it, else false and why (unknown label with the known ones,
        empty label, unusable spots file, move_base not available, move_base aborted with
        its reason, preempted by a newer call, ...)
  action client of ~move_base_action (move_base_msgs/MoveBaseAction), through an
        actionlib SimpleActionClient
  param ~spots_file (str): the spots file, default my_summit_localization's
        config/spots.yaml; the spot recorder's spots.txt reads just as well. Re-read when
        it changes. Missing or malformed: the node still starts, logs which file and what
        is wrong, and answers every call false with that reason.
  param ~move_base_action (str, default "move_base"): the move_base action's name
  param ~server_timeout (float [s] ROS time, default 10.0): how long a call waits for
        the action server before answering "move_base not available"
  param ~goal_timeout (float [s] ROS time, default 0 = none): cancel the goal and answer
        false when move_base has not finished it by then

Concurrency: rospy answers each call in its own thread. One goal is active at a time: a
newer call (one that gets as far as sending a goal) takes move_base over, and the older
call answers false "preempted by a newer call". The logic (lookup, answer texts) is
my_summit_navigation.spot_goals.
"""
import threading
import time

import rospkg
import rospy
from my_summit_navigation.goals import move_base_goal
from move_base_msgs.msg import MoveBaseAction

from my_summit_navigation import spot_goals as sg
from my_summit_navigation.srv import MyServiceMessage, MyServiceMessageResponse
from summit_nav_common.ros.action_client import SimpleActionClient

WAIT_STEP = 0.1         # [s] ROS time: how often a waiting call looks at its goal
CLOCK_WAIT_STEP = 0.05  # [s] wall: poll of /clock before the first sim-time wait
FEEDBACK_LOG_PERIOD = 5.0  # [s] wall: throttle of the progress log (debug)


class _Call:
    """One /get_coordinates call in flight: its label and its answer, set once."""

    def __init__(self, label):
        self.label = label
        self.done = threading.Event()
        self.answer = None       # (navigation_successfull, message)
        self._lock = threading.Lock()

    def finish(self, ok, message):
        """Set the answer unless one is set already (the first outcome wins)."""
        with self._lock:
            if self.answer is None:
                self.answer = (ok, message)
        self.done.set()


class GetCoordinatesServer:
    """/get_coordinates: label -> move_base goal -> answer.

    book: sg.SpotBook; client: SimpleActionClient (summit_nav_common.ros.action_client) of move_base;
    action_name: its name (for the answer texts); server_timeout, goal_timeout [s].
    """

    def __init__(self, book, client, action_name, server_timeout, goal_timeout):
        self.book = book
        self.client = client
        self.action_name = action_name
        self.server_timeout = server_timeout
        self.goal_timeout = goal_timeout
        self.lock = threading.Lock()   # guards self.current and every use of self.client
        self.current = None            # the _Call whose goal move_base works on
        self.service = rospy.Service("get_coordinates", MyServiceMessage, self.on_call)

    def on_call(self, req):
        ok, message = self.handle(req.label)
        (rospy.loginfo if ok else rospy.logwarn)(f"get_coordinates: '{req.label}': {message}")
        return MyServiceMessageResponse(navigation_successfull=ok, message=message)

    def handle(self, label):
        """One call: (navigation_successfull, message)."""
        self.book.refresh()
        spot, frame_id, refusal = self.book.lookup(label)
        if refusal is not None:
            return False, refusal
        label = label.strip()
        if not self._server_ready():
            return False, sg.answer_no_server(self.action_name, self.server_timeout)
        call = _Call(label)
        with self.lock:
            older = self.current
            self.current = call
            if older is not None:
                older.finish(False, sg.answer_preempted(label))
            rospy.loginfo(f"get_coordinates: sending {sg.describe(label, spot, frame_id)} to move_base")
            # A new goal replaces the active one in move_base (its SimpleActionServer
            # preempts it), and send_goal stops tracking the older goal here: the robot
            # drives on toward the newer spot without stopping in between.
            self.client.send_goal(self._goal(spot, frame_id),
                                  done_cb=lambda state, result: self._on_done(call, state),
                                  feedback_cb=lambda fb: self._on_feedback(call, fb))
        self._wait(call)
        with self.lock:
            if self.current is call:
                self.current = None
        return call.answer

    # -- move_base ---------------------------------------------------------------------
    @staticmethod
    def _goal(spot, frame_id):
        return move_base_goal(spot, frame_id, rospy.Time.now())

    def _server_ready(self):
        """True once the action server is connected, waiting up to server_timeout."""
        # under use_sim_time, ROS time stands still until /clock starts, and a ROS-time wait
        # would never end: wait for the clock first (the same timeout, in wall time)
        end = time.monotonic() + self.server_timeout
        while rospy.Time.now().is_zero() and time.monotonic() < end and not rospy.is_shutdown():
            time.sleep(CLOCK_WAIT_STEP)
        if rospy.Time.now().is_zero():
            return False
        return self.client.wait_for_server(rospy.Duration(self.server_timeout))

    def _on_done(self, call, state):
        # called by SimpleActionClient with self.client.gh still the finished goal's handle
        call.finish(*sg.answer_for_state(state, self.client.get_goal_status_text()))

    @staticmethod
    def _on_feedback(call, fb):
        p = fb.base_position.pose.position
        rospy.logdebug_throttle(FEEDBACK_LOG_PERIOD, f"get_coordinates: '{call.label}': robot at "
                                                     f"({p.x:.2f}, {p.y:.2f})")

    def _wait(self, call):
        """Block until the call has its answer: done, preempted, timed out or shut down."""
        deadline = rospy.Time.now() + rospy.Duration(self.goal_timeout) if self.goal_timeout > 0 else None
        while not call.done.wait(WAIT_STEP):
            if rospy.is_shutdown():
                self._cancel(call, sg.answer_shutdown())
            elif deadline is not None and rospy.Time.now() > deadline:
                self._cancel(call, sg.answer_goal_timeout(call.label, self.goal_timeout))

    def _cancel(self, call, message):
        with self.lock:
            if self.current is call:
                self.client.cancel_goal()
        call.finish(False, message)


def main():
    rospy.init_node("get_coordinates_service_server")
    default = rospkg.RosPack().get_path("my_summit_localization") + "/config/spots.yaml"
    path = rospy.get_param("~spots_file", "") or default
    action_name = rospy.get_param("~move_base_action", "move_base")
    server_timeout = float(rospy.get_param("~server_timeout", 10.0))
    goal_timeout = float(rospy.get_param("~goal_timeout", 0.0))
    book = sg.SpotBook(path)
    book.refresh()
    if book.error is not None:
        rospy.logerr(f"get_coordinates: cannot use the spots file {path}: {book.error}; "
                     "every call will be answered false with this reason until the file is fixed")
    else:
        rospy.loginfo(f"get_coordinates: {len(book.spots)} spots ({', '.join(book.spots)}) from {path}")
    client = SimpleActionClient(action_name, MoveBaseAction)
    server = GetCoordinatesServer(book, client, rospy.resolve_name(action_name), server_timeout, goal_timeout)
    rospy.loginfo(f"get_coordinates: {server.service.resolved_name} ready (move_base action "
                  f"{rospy.resolve_name(action_name)})")
    rospy.spin()


if __name__ == "__main__":
    main()
