"""The ROS adapter of the cruise (rospy): one class for scripts/auto_navigator and
scripts/patrol.py, around the pure state machine my_summit_navigation.cruise.Cruise.

It owns the move_base action client (summit_nav_common's SimpleActionClient, goals sent
with done / active / feedback callbacks as in the tutorial), the battery subscriber, the
costmap clearing, the latched ~summary and the "<node>: Cruise" diagnostic status
(summit_nav_common's NodeDiagnostics, the check being Cruise.status). Only the loop's
thread touches the Cruise: it feeds the Cruise the events that rospy's callback threads
queue and the clock, carries out its commands, and after each step stores a copy of
Cruise.status() under a lock; the diagnostic task (NodeDiagnostics' timer thread)
publishes that copy and never reads the Cruise.

Parameters both nodes read (read_common_params):
  ~move_base_action (str, move_base); ~frame_id (str, map)
  ~max_retries (int, 2): extra tries of an aborted or stalled goal, each after clearing
        the costmaps (move_base's ~clear_costmaps)
  ~movement_timeout (float [s], 30; patrol also reads ~stuck_timeout): no 0.1 m of progress
        toward the goal for this long -> cancel, clear the costmaps, retry
  ~battery_topic (str, /battery_state): sensor_msgs/BatteryState, percentage 0..1; a
        message with present false, a NaN percentage or one outside 0..1 is ignored (one
        warning naming the topic per kind); messages that come while the node waits for
        move_base are handled before the first goal (a low battery: the dock first)
  ~low_battery (0.2), ~resume_battery (0.9), ~critical_battery (0.05): fractions of a charge
  ~battery_timeout (float [s], 5): no battery message by then -> one warning, cruise on
  ~charge_start_timeout (float [s], 10): at the dock, the charger must work within this
        long and keep working over each such period (power_supply_status CHARGING or
        FULL with the level not falling; a driver that reports UNKNOWN: the level
        rising), else the dock goal is sent again (a retry; after ~max_retries the
        cruise stops, dock_unreachable)
"""
import json
import queue
import threading

import rospy
from move_base_msgs.msg import MoveBaseAction
from sensor_msgs.msg import BatteryState
from std_msgs.msg import String

from summit_nav_common.diagnostic_checks import Check
from summit_nav_common.ros.action_client import SimpleActionClient
from summit_nav_common.ros.diagnostics import NodeDiagnostics
from summit_nav_common.ros.move_base_services import clear_costmaps
from my_summit_navigation import cruise as cr
from my_summit_navigation.goals import move_base_goal, wait_clock

SERVER_WAIT = 60.0   # [s] for the move_base action server at the start
LOOP_PERIOD = 0.1    # [s] wall: how long the loop waits for an event before ticking
CLEAR_WAIT = 5.0     # [s] for move_base's clear_costmaps service


def read_common_params(stuck_timeout_alias=False):
    """The parameters both cruise nodes share (module docstring), as a dict."""
    timeout = rospy.get_param("~movement_timeout", None)
    if timeout is None and stuck_timeout_alias:
        timeout = rospy.get_param("~stuck_timeout", None)
    return {"action": rospy.get_param("~move_base_action", "move_base"),
            "frame": rospy.get_param("~frame_id", "map"),
            "max_retries": int(rospy.get_param("~max_retries", 2)),
            "movement_timeout": float(30.0 if timeout is None else timeout),
            "battery_topic": rospy.get_param("~battery_topic", "/battery_state"),
            "battery": cr.BatteryLimits(low=float(rospy.get_param("~low_battery", 0.2)),
                                        resume=float(rospy.get_param("~resume_battery", 0.9)),
                                        critical=float(rospy.get_param("~critical_battery", 0.05)),
                                        timeout=float(rospy.get_param("~battery_timeout", 5.0)),
                                        charge_start_timeout=float(rospy.get_param("~charge_start_timeout",
                                                                                   10.0))).check()}


class CruiseNode:
    """Runs one cruise through move_base.

    stops: list of cruise.Stop; laps: int (0 = forever); dock: Stop or None; params: from
    read_common_params; prefix: names a lap in the log ("lap", "patrol round");
    summary_text: Cruise -> the ~summary text (default: the summary as JSON).
    """

    def __init__(self, stops, laps, dock, params, prefix="lap", summary_text=None):
        self.params = params
        self.stops, self.laps, self.dock, self.prefix = stops, laps, dock, prefix
        self.summary_text = summary_text or (lambda cruise, summary: json.dumps(summary))
        self.cruise = None
        self.events = queue.Queue()
        self.client = SimpleActionClient(params["action"], MoveBaseAction)
        self.summary_pub = rospy.Publisher("~summary", String, queue_size=1, latch=True)
        self.battery_sub = rospy.Subscriber(params["battery_topic"], BatteryState, self._on_battery, queue_size=10)
        self.diagnostics = NodeDiagnostics(hardware_id="none")   # software, no device: as move_base's
        self._status_lock = threading.Lock()
        self._status = Check(cr.WARN, f"waiting for the move_base action server '{params['action']}'")
        self.diagnostics.add("Cruise", self._diagnose)
        self._last_activity = None
        self._battery_warned = set()    # battery_problem texts already warned about

    # -- callbacks: queue events only --------------------------------------------------------
    def _on_battery(self, msg):
        problem = cr.battery_problem(msg.percentage, msg.present)
        if problem is None:
            self.events.put(("battery", msg.percentage, msg.power_supply_status))
            return
        if problem not in self._battery_warned:
            self._battery_warned.add(problem)
            rospy.logwarn(f"{self.params['battery_topic']}: ignoring BatteryState messages with {problem} "
                          f"(this one: percentage {msg.percentage:g}, present {msg.present}); warned once")

    def _callbacks(self, goal_id):
        def done(state, _result):
            self.events.put(("done", goal_id, state, self.client.get_goal_status_text()))

        def active():
            rospy.logdebug(f"goal {goal_id} active")

        def feedback(fb):
            p = fb.base_position.pose.position
            self.events.put(("feedback", goal_id, p.x, p.y))
        return done, active, feedback

    def request_return_home(self):
        """Queue a return home (patrol's ~return_home); (accepted, message)."""
        if self.cruise is None or self.cruise.home is None:
            return False, "the cruise has not started yet (no home pose)"
        if self.cruise.done:
            return False, "the cruise is over"
        self.events.put(("home",))
        return True, "interrupting the round; going home"

    def _diagnose(self, _now):
        """The diagnostic task (the timer's thread): the loop's last copy of the status."""
        with self._status_lock:
            return self._status

    # -- the loop ----------------------------------------------------------------------------
    def run(self, home=None):
        """Wait for move_base, cruise, publish the summary; returns the summary dict.
        home: a Stop, or a callable giving one once move_base is up (patrol's start pose)."""
        # Under use_sim_time ROS time is 0 until /clock runs, and a ROS-time wait started
        # then ends at once: wait (wall time) for the clock first.
        if not wait_clock(SERVER_WAIT):
            raise RuntimeError(f"no ROS time (/clock) within {SERVER_WAIT:.0f} s")
        if not self.client.wait_for_server(rospy.Duration(SERVER_WAIT)):
            raise RuntimeError(f"no move_base action server '{self.params['action']}' within {SERVER_WAIT:.0f} s")
        home = home() if callable(home) else home
        p = self.params
        self.cruise = cr.Cruise(self.stops, self.laps, p["max_retries"], p["movement_timeout"], dock=self.dock,
                                home=home, battery=p["battery"], prefix=self.prefix)
        self._take_early_battery()
        self._execute(self.cruise.start(self._now()))
        self._update_diagnostics()
        while not rospy.is_shutdown() and not self.cruise.done:
            try:
                event = self.events.get(timeout=LOOP_PERIOD)
            except queue.Empty:
                event = None
            if event is not None:
                self._execute(self._handle(event))
            if not self.cruise.done:
                self._execute(self.cruise.tick(self._now()))
            self._update_diagnostics()
        if not self.cruise.done:      # shut down mid-run: cancel the goal, report what was done
            self.client.cancel_goal()
        return self.cruise.summary(self._now())

    def _take_early_battery(self):
        """Feed the battery messages that came while waiting for move_base to the Cruise
        before it starts, so that a robot started with a low battery docks first; other
        queued events (a return home asked meanwhile) stay queued for the loop."""
        others = []
        while True:
            try:
                event = self.events.get_nowait()
            except queue.Empty:
                break
            if event[0] == "battery":
                self._execute(self._handle(event))
            else:
                others.append(event)
        for event in others:
            self.events.put(event)

    def spin(self):
        """After the run: keep the diagnostics (and the latched summary) up until shutdown."""
        rospy.spin()

    def _now(self):
        return rospy.Time.now().to_sec()

    def _handle(self, event):
        now, kind = self._now(), event[0]
        if kind == "done":
            return self.cruise.goal_done(event[1], event[2], event[3], now)
        if kind == "feedback":
            return self.cruise.feedback(event[1], event[2], event[3], now)
        if kind == "battery":
            return self.cruise.battery(event[1], now, event[2])
        accepted, cmds = self.cruise.return_home(now)
        if accepted:
            rospy.loginfo("return home requested: interrupting the cruise")
        return cmds

    def _execute(self, commands):
        for cmd in commands:
            if isinstance(cmd, cr.Log):
                {cr.OK: rospy.loginfo, cr.WARN: rospy.logwarn, cr.ERROR: rospy.logerr}[cmd.level](cmd.text)
            elif isinstance(cmd, cr.Send):
                done, active, feedback = self._callbacks(cmd.goal_id)
                self.client.send_goal(move_base_goal(cmd.stop.spot, cmd.stop.frame, rospy.Time.now()),
                                      done_cb=done, active_cb=active, feedback_cb=feedback)
            elif isinstance(cmd, cr.Cancel):
                self.client.cancel_goal()
            elif isinstance(cmd, cr.ClearCostmaps):
                clear_costmaps(self.params["action"], CLEAR_WAIT)
            elif isinstance(cmd, cr.Finish):
                text = self.summary_text(self.cruise, cmd.summary)
                rospy.loginfo(f"summary: {text}")
                self.summary_pub.publish(String(text))
            else:
                raise TypeError(f"unknown cruise command {cmd!r}")

    def _update_diagnostics(self):
        """In the loop, after each step: hand the diagnostic task a copy of the status
        (a Check, immutable), and publish at once when the activity changes
        (NodeDiagnostics' timer publishes at ~diagnostic_period otherwise)."""
        status = self.cruise.status()
        with self._status_lock:
            self._status = status
        activity = (self.cruise.activity, self.cruise.end_state)
        if activity != self._last_activity:
            self._last_activity = activity
            self.diagnostics.updater.force_update()
