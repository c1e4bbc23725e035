#!/usr/bin/python3
"""patrol: cruise a list of spots through move_base, recovering by itself (a thin adapter).

    roslaunch my_summit_navigation patrol.launch [labels:="[table, room, turtle]"] [rounds:=1]
    rosservice call /patrol/return_home      # interrupt the round and go home

  action client of ~move_base_action (default move_base), SimpleActionClient with
        done / active / feedback callbacks
  param ~labels (list of str): spots of ~spots_file to patrol, in order; or
  param ~poses (list of [x, y, yaw_deg] or {name, x, y, yaw_deg}): poses in ~frame_id
  param ~spots_file (str): default my_summit_localization's config/spots.yaml
  param ~rounds (int, default 1; 0 = forever)
  param ~max_retries (int, default 2): extra tries of an aborted or stuck goal, each after
        clearing the costmaps (move_base's ~clear_costmaps)
  param ~stuck_timeout (float [s], default 30): no 0.1 m of progress toward the goal for
        this long (from move_base's feedback): the goal is canceled and retried
  param ~home (label, or [x, y, yaw_deg]; default: where the robot stood at the start)
  srv   ~return_home (std_srvs/Trigger): cancel the current goal, drive home, stop
  topic ~summary (std_msgs/String, latched): the summary line when the patrol ends

Logs one line per goal (reached / retrying / SKIPPED with the reason) and a summary:
reached, retried, skipped, time. The decisions are my_summit_navigation.patrol_logic.
"""
import math
import threading

import rospkg
import rospy
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from move_base_msgs.msg import MoveBaseAction
from std_msgs.msg import String
from std_srvs.srv import Empty, Trigger, TriggerResponse

from my_summit_localization.spots import Spot
from summit_nav_common.geometry import quaternion_to_yaw
from summit_nav_common.ros.action_client import SimpleActionClient
from my_summit_navigation import patrol_logic as pl
from my_summit_navigation.goals import move_base_goal
from my_summit_navigation.spot_goals import STATE_NAMES, SpotBook

SERVER_WAIT = 60.0   # [s] for the move_base action server at the start
RETRY_PAUSE = 1.0    # [s] after clearing the costmaps, before the retry (fresh sensor data)


class Patrol:
    def __init__(self):
        self.action = rospy.get_param("~move_base_action", "move_base")
        self.frame = rospy.get_param("~frame_id", "map")
        self.rounds = int(rospy.get_param("~rounds", 1))
        self.max_retries = int(rospy.get_param("~max_retries", 2))
        self.watch = pl.ProgressWatch(float(rospy.get_param("~stuck_timeout", 30.0)))
        default_spots = rospkg.RosPack().get_path("my_summit_localization") + "/config/spots.yaml"
        self.book = SpotBook(rospy.get_param("~spots_file", default_spots))
        labels, poses = rospy.get_param("~labels", None), rospy.get_param("~poses", None)
        if labels is None and poses is None:
            raise ValueError("give ~labels (spots of ~spots_file) or ~poses ([x, y, yaw_deg] in ~frame_id)")
        if labels is not None and not isinstance(labels, list):
            labels = [labels]
        self.stops = pl.build_stops(labels=labels, book=self.book, frame=self.frame) if labels is not None \
            else pl.build_stops(poses=poses, frame=self.frame)
        self.log = pl.PatrolLog()
        self.home_requested = threading.Event()
        self.client = SimpleActionClient(self.action, MoveBaseAction)
        self.summary_pub = rospy.Publisher("~summary", String, queue_size=1, latch=True)
        self.tf = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf)
        self.home = None
        self._done = threading.Event()
        self._state = None
        rospy.Service("~return_home", Trigger, self._on_return_home)

    # -- actionlib callbacks ------------------------------------------------------------
    def _active(self):
        rospy.logdebug("patrol: goal active")

    def _feedback(self, fb):
        p = fb.base_position.pose.position
        self._dist = math.hypot(p.x - self._goal_xy[0], p.y - self._goal_xy[1])

    def _finished(self, state, result):
        self._state = state
        self._done.set()

    def _on_return_home(self, _req):
        if self.home is None:
            return TriggerResponse(False, "the patrol has not started yet (no home pose)")
        self.home_requested.set()
        return TriggerResponse(True, "interrupting the round; going home")

    # -- driving --------------------------------------------------------------------------
    def go(self, stop):
        """Send stop's goal and wait: (state, text, stuck); stuck cancels the goal."""
        self._done.clear()
        self._state, self._dist = None, math.inf
        self._goal_xy = (stop.spot.x, stop.spot.y)
        self.watch.reset(rospy.Time.now().to_sec())
        self.client.send_goal(move_base_goal(stop.spot, stop.frame, rospy.Time.now()), done_cb=self._finished,
                              active_cb=self._active, feedback_cb=self._feedback)
        stuck = False
        while not self._done.wait(0.1) and not rospy.is_shutdown():
            if stop.name != "home" and self.home_requested.is_set():
                self.client.cancel_goal()
                self._done.wait(5.0)
                return GoalStatus.PREEMPTED, "return home requested", False
            if self._dist < math.inf and self.watch.update(self._dist, rospy.Time.now().to_sec()):
                stuck = True
                self.client.cancel_goal()
                self._done.wait(5.0)
                break
        return self._state, self.client.get_goal_status_text(), stuck

    def clear_costmaps(self):
        name = rospy.resolve_name(self.action) + "/clear_costmaps"
        try:
            rospy.wait_for_service(name, 5.0)
            rospy.ServiceProxy(name, Empty)()
        except (rospy.ROSException, rospy.ServiceException) as e:
            rospy.logwarn(f"patrol: could not clear the costmaps ({name}): {e}")

    def start_pose(self):
        t = self.tf.lookup_transform(self.frame, "base_footprint", rospy.Time(0), rospy.Duration(30.0)).transform
        return Spot.from_xy_yaw(t.translation.x, t.translation.y, quaternion_to_yaw(t.rotation))

    def resolve_home(self):
        home = rospy.get_param("~home", None)
        if home is None:
            return pl.Stop("home", self.start_pose(), self.frame)
        stop = pl.build_stops(labels=[home], book=self.book, frame=self.frame)[0] if isinstance(home, str) \
            else pl.build_stops(poses=[home], frame=self.frame)[0]
        if stop.error:
            raise ValueError(f"~home: {stop.error}")
        return pl.Stop("home", stop.spot, stop.frame)

    def run(self):
        if not self.client.wait_for_server(rospy.Duration(SERVER_WAIT)):
            raise RuntimeError(f"no move_base action server '{self.action}' within {SERVER_WAIT:.0f} s")
        self.home = self.resolve_home()
        for stop in self.stops:
            if stop.error:
                rospy.logwarn(f"patrol: '{stop.name}' will be skipped: {stop.error}")
        t0 = rospy.Time.now().to_sec()
        round_no = 0
        while not rospy.is_shutdown() and (self.rounds == 0 or round_no < self.rounds) \
                and not self.home_requested.is_set():
            round_no += 1
            for stop in self.stops:
                if rospy.is_shutdown() or self.home_requested.is_set():
                    break
                if stop.error:
                    rospy.logwarn(self.log.goal_line(round_no, stop, pl.SKIP, stop.error, 0.0))
                    continue
                attempt = 0
                while not rospy.is_shutdown():
                    attempt += 1
                    g0 = rospy.Time.now().to_sec()
                    state, text, stuck = self.go(stop)
                    if self.home_requested.is_set():
                        break
                    action, reason = pl.decide(state, text, attempt, self.max_retries, stuck)
                    line = self.log.goal_line(round_no, stop, action, reason, rospy.Time.now().to_sec() - g0)
                    (rospy.loginfo if action == pl.NEXT else rospy.logwarn)(line)
                    if action != pl.RETRY:
                        break
                    self.clear_costmaps()
                    rospy.sleep(RETRY_PAUSE)
        if self.home_requested.is_set() and not rospy.is_shutdown():
            state, text, _ = self.go(self.home)
            rospy.loginfo(f"patrol: return home: {STATE_NAMES.get(state, state)} ({text})")
        summary = self.log.summary(round_no, rospy.Time.now().to_sec() - t0)
        rospy.loginfo(summary)
        self.summary_pub.publish(String(summary))


def main():
    rospy.init_node("patrol")
    try:
        patrol = Patrol()
        patrol.run()
    except (ValueError, RuntimeError, tf2_ros.TransformException) as e:
        rospy.logerr(f"patrol: {e}")
        raise SystemExit(1)
    rospy.spin()   # keep ~summary and ~return_home up until shut down


if __name__ == "__main__":
    main()
