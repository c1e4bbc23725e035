#!/usr/bin/python3
"""explore: frontier exploration with move_base, in the manner of explore_lite.

    roslaunch my_summit_navigation explore.launch sim:=true [world:=...] [x:= y:= yaw:=]

Reads move_base's global costmap (on slam_gmapping's growing map), picks the cheapest
frontier (my_summit_navigation.frontiers: potential_scale x travel distance - gain_scale
x size), sends move_base a goal there and repeats at planner_frequency. A goal move_base
aborts, or one with no progress for progress_timeout, is blacklisted (the timer runs on
when the choice flips back to a goal it was driving to moments ago: frontiers.GoalProgress);
one the robot comes within REACHED of, its frontier in the laser's view, counts as
reached. When no frontier is left, the goals given up for no progress get one more try
(frontiers.Blacklist). When none is left then (or none can be reached, or the robot is
stuck) it stops, says so, and saves the map.

  action client of move_base (move_base_msgs/MoveBaseAction)
  sub   ~costmap_topic (default move_base/global_costmap/costmap, nav_msgs/OccupancyGrid)
  sub   map (nav_msgs/OccupancyGrid): the SLAM map, saved at the end
  pub   ~frontiers (geometry_msgs/PoseArray): the frontier goals, cheapest first
  pub   ~done (std_msgs/Bool, latched): true once exploration is over
  pub   ~summary (std_msgs/String, latched): why it ended, goals sent, blacklisted, time
  params (explore_lite's): ~robot_base_frame (base_footprint), ~planner_frequency (0.33
        Hz), ~progress_timeout (30 s), ~potential_scale (3.0), ~gain_scale (1.0),
        ~min_frontier_size (0.75 m); ours: ~goal_margin (0.3 m) and ~goal_search (1.0 m):
        the goal steps back from the frontier's edge to a cell goal_margin from anything
        unreachable, within goal_search (frontiers.margin_goal); ~stuck_goals (6) and
        ~stuck_distance (0.5 m): that many goals given up in a row for no progress while the
        robot stayed within stuck_distance of where it was at the first means the robot is
        stuck, not the frontiers unreachable: exploration ends and says so, map saved
        (frontiers.StuckWatch; 0: never); ~stall_hold (5 s): a goal without progress for
        that long is held (no switching to another frontier) until it is reached, aborted or
        given up, so that move_base's recoveries get their turn (0: never held);
        ~save_map (base path; default $ROS_HOME/explored_map; empty: do not save),
        ~max_time (0 = no limit [s]).
"""
import math
import os
import threading

import actionlib
import numpy as np
import rospkg
import rospy
import tf2_ros
from geometry_msgs.msg import Pose, PoseArray
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid
from rospy.numpy_msg import numpy_msg
from std_msgs.msg import Bool, String

from summit_nav_common.geometry import quaternion_to_yaw
from my_summit_navigation import frontiers as fr

SUCCEEDED, ABORTED = 3, 4
# [m] this near the goal counts as there: what can be seen from it has been seen. Beside a
# wall move_base may be unable to turn to the goal heading (DWA: "cannot rotate to the
# goal heading") and never report the goal reached; explore waited progress_timeout there
# and blacklisted it as failed, or move_base aborted it (3 of 5 built-in runs lost time so).
# Only with the frontier in the laser's view (frontiers.in_view): the first goal, the
# 90 deg behind the robot at its spawn, lies next to it, and counted as reached at once it
# was never looked at (a 2-3% wedge of the two-room world left unknown, 1 CI run of 3).
REACHED = 0.3
SAME_GOAL = 0.5      # [m] a frontier goal this close to the active one keeps it
EMPTY_ROUNDS = 4     # planning rounds in a row without a frontier before it is over


class Explore:
    def __init__(self):
        self.base_frame = rospy.get_param("~robot_base_frame", "base_footprint")
        self.period = 1.0 / max(1e-3, float(rospy.get_param("~planner_frequency", 0.33)))
        self.progress_timeout = float(rospy.get_param("~progress_timeout", 30.0))
        self.params = fr.FrontierParams(potential_scale=float(rospy.get_param("~potential_scale", 3.0)),
                                        gain_scale=float(rospy.get_param("~gain_scale", 1.0)),
                                        min_frontier_size=float(rospy.get_param("~min_frontier_size", 0.75)),
                                        goal_margin=float(rospy.get_param("~goal_margin", 0.3)),
                                        goal_search=float(rospy.get_param("~goal_search", 1.0)))
        self.save_base = rospy.get_param("~save_map", os.path.join(rospkg.get_ros_home(), "explored_map"))
        self.max_time = float(rospy.get_param("~max_time", 0.0))
        self.stall_hold = float(rospy.get_param("~stall_hold", 5.0))
        self.stuck = fr.StuckWatch(int(rospy.get_param("~stuck_goals", 6)),
                                   float(rospy.get_param("~stuck_distance", 0.5)))
        self.lock = threading.Lock()
        self.costmap = None
        self.map_msg = None
        self.blacklist = fr.Blacklist(self.params.blacklist_radius)
        self.goal = None            # (x, y) of the active goal
        self.goal_centroid = None   # (x, y) of its frontier's centroid
        self.goal_state = None
        # no progress for progress_timeout towards a goal, kept across goal switches
        self.progress = fr.GoalProgress(self.progress_timeout, same=SAME_GOAL)
        self.sent = 0
        self.failed = 0             # goals aborted or without progress
        self.empty_rounds = 0       # planning rounds in a row that found no frontier
        self.tf = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf)
        self.client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        rospy.Subscriber(rospy.get_param("~costmap_topic", "move_base/global_costmap/costmap"),
                         numpy_msg(OccupancyGrid), self._on_costmap, queue_size=1, buff_size=2 ** 25)
        rospy.Subscriber("map", numpy_msg(OccupancyGrid), lambda m: setattr(self, "map_msg", m),
                         queue_size=1, buff_size=2 ** 25)
        self.frontier_pub = rospy.Publisher("~frontiers", PoseArray, queue_size=1, latch=True)
        self.done_pub = rospy.Publisher("~done", Bool, queue_size=1, latch=True)
        self.summary_pub = rospy.Publisher("~summary", String, queue_size=1, latch=True)
        self.done_pub.publish(Bool(False))

    def _on_costmap(self, msg):
        with self.lock:
            self.costmap = msg

    def _on_done(self, state, _result):
        with self.lock:
            self.goal_state = state

    def robot_pose(self):
        """(x, y, yaw) of the robot in the costmap's frame."""
        tr = self.tf.lookup_transform(self.costmap.header.frame_id, self.base_frame, rospy.Time(0),
                                      rospy.Duration(1.0)).transform
        return tr.translation.x, tr.translation.y, quaternion_to_yaw(tr.rotation)

    def send(self, frontier, robot):
        gx, gy = frontier.goal
        # arrive heading the way the robot drives there (no turn on the spot beside a wall
        # at the end; the 270 deg laser sees the frontier ahead anyway), or facing the
        # frontier when it would be behind
        yaw = fr.goal_heading(robot, frontier.goal, frontier.centroid)
        goal = MoveBaseGoal()
        goal.target_pose.header.frame_id = self.costmap.header.frame_id
        goal.target_pose.header.stamp = rospy.Time.now()
        goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = gx, gy
        goal.target_pose.pose.orientation.z, goal.target_pose.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        with self.lock:
            self.goal, self.goal_state = (gx, gy), None
            self.goal_centroid = frontier.centroid
        again = self.progress.start((gx, gy), rospy.Time.now().to_sec())
        self.sent += 1
        self.client.send_goal(goal, done_cb=self._on_done)
        rospy.loginfo(f"explore: goal {self.sent}: frontier of {frontier.size:.1f} m at ({gx:.2f}, {gy:.2f}), "
                      f"{frontier.distance:.1f} m away" + (" (again: its progress timer runs on)" if again else ""))

    def give_up_goal(self, why, robot, no_progress=False):
        """Blacklist the active goal; returns the reason exploration is over when the
        robot, not the goal, is the problem (see StuckWatch), else None. Only goals given
        up for no progress count: move_base aborts a goal in an obstacle at once."""
        rospy.logwarn(f"explore: blacklisting ({self.goal[0]:.2f}, {self.goal[1]:.2f}): {why} "
                      f"(robot at ({robot[0]:.2f}, {robot[1]:.2f}))")
        self.blacklist.add(self.goal, no_progress=no_progress)
        self.failed += 1
        self.client.cancel_goal()
        self.goal = None
        if no_progress and self.stuck.given_up(robot):
            return (f"the robot is stuck at ({robot[0]:.2f}, {robot[1]:.2f}): {self.stuck.goals} goals in a row "
                    f"given up without it moving {self.stuck.distance:.1f} m")
        return None

    def step(self):
        """One planning round; returns the reason exploration is over, or None."""
        with self.lock:
            cm = self.costmap
        if cm is None:
            rospy.loginfo_throttle(10.0, "explore: waiting for the global costmap")
            return None
        try:
            pose = self.robot_pose()
        except tf2_ros.TransformException as e:
            rospy.logwarn_throttle(10.0, f"explore: no robot pose: {e}")
            return None
        robot = pose[:2]
        now = rospy.Time.now().to_sec()
        self.stuck.update(robot)
        # the active goal: ended, or no progress?
        if self.goal is not None:
            over = None
            if self.goal_state == ABORTED:
                over = self.give_up_goal("move_base aborted it", robot)
            else:
                d = math.hypot(robot[0] - self.goal[0], robot[1] - self.goal[1])
                if self.goal_state is not None or (d <= REACHED and fr.in_view(pose, self.goal_centroid)):
                    # reached (or ended otherwise), or within REACHED and facing the frontier
                    # (the next goal preempts it): what can be seen from there has been
                    # seen; a frontier whose goal falls here again is a pocket the laser
                    # cannot fill
                    self.blacklist.add(self.goal)
                    self.goal = None
                elif self.progress.update(d, now):
                    over = self.give_up_goal(f"no progress for {self.progress_timeout:.0f} s", robot,
                                             no_progress=True)
            if over is not None:
                return over
        info = cm.info
        grid = np.asarray(cm.data, np.int16).reshape(info.height, info.width)
        found = fr.find_frontiers(grid, info.resolution, (info.origin.position.x, info.origin.position.y),
                                  robot, self.params, self.blacklist)
        pa = PoseArray()
        pa.header = cm.header
        for f in found:
            p = Pose()
            p.position.x, p.position.y, p.orientation.w = f.goal[0], f.goal[1], 1.0
            pa.poses.append(p)
        self.frontier_pub.publish(pa)
        if not found:
            if self.goal is not None and self.goal_state is None:
                return None   # let the last goal finish: it may uncover more
            # Only over when it stays so for EMPTY_ROUNDS rounds: the costmap follows a map
            # published every few seconds, and the robot may stand in a cell the latest
            # update marked (then nothing is reachable from it for a moment).
            self.empty_rounds += 1
            if self.empty_rounds < EMPTY_ROUNDS:
                rospy.loginfo(f"explore: no frontier found ({self.empty_rounds}/{EMPTY_ROUNDS}); looking again")
                return None
            again = self.blacklist.second_chance()
            if again:
                # goals given up for no progress may have met a stall, not a closed way
                for g in again:
                    self.progress.forget(g)
                self.empty_rounds = 0
                rospy.logwarn(f"explore: no frontier left but {len(again)} given up for no progress: "
                              "one more try at " + ", ".join(f"({x:.2f}, {y:.2f})" for x, y in again))
                return None
            beyond = fr.frontiers_out_of_reach(grid, info.resolution, (info.origin.position.x, info.origin.position.y),
                                               robot, self.params)
            if self.failed == 0 and beyond == 0:
                return "no frontiers left"
            why = [f"{self.failed} goals failed and blacklisted"] if self.failed else []
            if beyond:
                why.append(f"{beyond} frontier{'s' if beyond > 1 else ''} seen where the robot cannot pass")
            return f"no reachable frontier left ({'; '.join(why)})"
        self.empty_rounds = 0
        if self.goal is not None and any(math.hypot(f.goal[0] - self.goal[0], f.goal[1] - self.goal[1]) < SAME_GOAL
                                         for f in found[:3]):
            return None
        if self.goal is not None and 0 < self.stall_hold <= self.progress.stalled(now):
            # A goal the robot has made no progress towards for stall_hold is kept until
            # it is reached, aborted or given up: each new goal restarts move_base's
            # recoveries, and on willow-full the choice flipped between two frontiers every
            # 4-6 s while the robot stood wedged in a pocket, so move_base never got past
            # its first recovery to the one that would have turned it out (turn_around).
            return None
        self.send(found[0], robot)
        return None

    def save(self):
        if not self.save_base:
            return "not saved (~save_map empty)"
        from summit_nav_common.map_io import GridMap, save_map
        m = self.map_msg
        if m is None:
            return "not saved: no map received on 'map'"
        o = m.info.origin
        yaw = 2 * math.atan2(o.orientation.z, o.orientation.w)
        grid = GridMap(np.asarray(m.data, np.int8).reshape(m.info.height, m.info.width), m.info.resolution,
                       (o.position.x, o.position.y, yaw))
        try:
            save_map(grid, self.save_base)
        except Exception as e:  # MapError (folder missing, not writable) or OSError
            return f"NOT saved: {e}"
        return f"saved to {self.save_base}.pgm/.yaml"

    def run(self):
        while not self.client.wait_for_server(rospy.Duration(2.0)):
            rospy.loginfo_throttle(10.0, "explore: waiting for the move_base action server")
            if rospy.is_shutdown():
                return
        t0 = rospy.Time.now().to_sec()
        rate = rospy.Rate(1.0 / self.period)
        reason = None
        while not rospy.is_shutdown() and reason is None:
            reason = self.step()
            if reason is None and self.max_time > 0 and rospy.Time.now().to_sec() - t0 > self.max_time:
                reason = f"time limit {self.max_time:.0f} s reached"
            if reason is None:
                rate.sleep()
        if rospy.is_shutdown():
            return
        self.client.cancel_all_goals()
        saved = self.save()
        summary = (f"exploration over: {reason}; {self.sent} goals sent, {self.failed} failed, "
                   f"{rospy.Time.now().to_sec() - t0:.0f} s; map {saved}")
        rospy.loginfo("explore: " + summary)
        self.summary_pub.publish(String(summary))
        self.done_pub.publish(Bool(True))


def main():
    rospy.init_node("explore")
    Explore().run()
    rospy.spin()


if __name__ == "__main__":
    main()
