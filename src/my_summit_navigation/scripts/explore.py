#!/usr/bin/python3
"""explore: frontier exploration with move_base, in the manner of explore_lite.

    roslaunch my_summit_navigation explore.launch sim:=true [world:=...] [x:= y:= yaw:=]

Reads move_base's global costmap (on slam_gmapping's growing map), picks the cheapest
frontier (my_summit_navigation.frontiers: potential_scale x travel distance - gain_scale
x size), sends move_base a goal there and repeats at planner_frequency. The decisions of
each round are my_summit_navigation.exploration.Explore's; this node adapts ROS to it. A goal move_base
aborts, or one with no progress for progress_timeout, is blacklisted (the timer runs on
when the choice flips back to a goal it was driving to moments ago: frontiers.GoalProgress);
one the robot comes within REACHED of, its frontier in the laser's view, counts as
reached. When no frontier is left, the goals given up for no progress get one more try
(frontiers.Blacklist); when frontiers are seen where the robot cannot pass, move_base's
costmaps are cleared once (move_base/clear_costmaps) and it looks again. When none is
left then (or none can be reached, or the robot is stuck) it stops, says so, and saves
the map.

  action client of move_base (move_base_msgs/MoveBaseAction)
  sub   ~costmap_topic (default move_base/global_costmap/costmap, nav_msgs/OccupancyGrid)
        and its _updates (map_msgs/OccupancyGridUpdate), as move_base publishes them
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
from summit_nav_common.ros.costmap_client import CostmapClient
from summit_nav_common.ros.move_base_services import clear_costmaps
from my_summit_navigation import frontiers as fr
from my_summit_navigation.exploration import Explore

CLEAR_WAIT = 5.0   # [s] for move_base's clear_costmaps service


class ExploreNode:
    """The ROS side of exploration.Explore: parameters, topics, the move_base client."""

    def __init__(self):
        self.base_frame = rospy.get_param("~robot_base_frame", "base_footprint")
        self.period = 1.0 / max(1e-3, float(rospy.get_param("~planner_frequency", 0.33)))
        params = fr.FrontierParams(potential_scale=float(rospy.get_param("~potential_scale", 3.0)),
                                   gain_scale=float(rospy.get_param("~gain_scale", 1.0)),
                                   min_frontier_size=float(rospy.get_param("~min_frontier_size", 0.75)),
                                   goal_margin=float(rospy.get_param("~goal_margin", 0.3)),
                                   goal_search=float(rospy.get_param("~goal_search", 1.0)))
        self.explore = Explore(params, progress_timeout=float(rospy.get_param("~progress_timeout", 30.0)),
                               stall_hold=float(rospy.get_param("~stall_hold", 5.0)),
                               stuck_goals=int(rospy.get_param("~stuck_goals", 6)),
                               stuck_distance=float(rospy.get_param("~stuck_distance", 0.5)))
        self.save_base = rospy.get_param("~save_map", os.path.join(rospkg.get_ros_home(), "explored_map"))
        self.max_time = float(rospy.get_param("~max_time", 0.0))
        self.lock = threading.Lock()   # the Explore, shared with the action client's done callback
        self.map_msg = None
        self.tf = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf)
        # the plain ActionClient: each goal's handle reports its own end (SimpleActionClient
        # tracks one goal, and a late end of the previous one can mark the next one done)
        self.client = actionlib.ActionClient("move_base", MoveBaseAction)
        self.goal_handle = None   # the active goal's (kept: the client holds it weakly)
        self.costmap = CostmapClient(rospy.get_param("~costmap_topic", "move_base/global_costmap/costmap"))
        rospy.Subscriber("map", numpy_msg(OccupancyGrid), lambda m: setattr(self, "map_msg", m),
                         queue_size=1, buff_size=2 ** 25)
        self.frontier_pub = rospy.Publisher("~frontiers", PoseArray, queue_size=1, latch=True)
        self.done_pub = rospy.Publisher("~done", Bool, queue_size=1, latch=True)
        self.summary_pub = rospy.Publisher("~summary", String, queue_size=1, latch=True)
        self.done_pub.publish(Bool(False))

    def _on_transition(self, number, handle):
        if handle.get_comm_state() == actionlib.CommState.DONE:
            with self.lock:
                self.explore.goal_done(number, handle.get_goal_status())

    def robot_pose(self, frame):
        """(x, y, yaw) of the robot in frame."""
        tr = self.tf.lookup_transform(frame, self.base_frame, rospy.Time(0), rospy.Duration(1.0)).transform
        return tr.translation.x, tr.translation.y, quaternion_to_yaw(tr.rotation)

    def step(self):
        """One planning round; returns the reason exploration is over, or None."""
        cm = self.costmap.snapshot()
        if cm is None:
            rospy.loginfo_throttle(10.0, "explore: waiting for the global costmap")
            return None
        header, info, data = cm
        try:
            pose = self.robot_pose(header.frame_id)
        except tf2_ros.TransformException as e:
            rospy.logwarn_throttle(10.0, f"explore: no robot pose: {e}")
            return None
        grid = data.astype(np.int16)
        with self.lock:
            r = self.explore.step(rospy.Time.now().to_sec(), pose, grid, info.resolution,
                                  (info.origin.position.x, info.origin.position.y), header.stamp.to_sec())
        for level, text in r.logs:
            (rospy.logwarn if level == "warn" else rospy.loginfo)(f"explore: {text}")
        if r.cancel and self.goal_handle is not None:
            self.goal_handle.cancel()
        if r.clear_costmaps:
            clear_costmaps("move_base", CLEAR_WAIT, who="explore: ")
        if r.frontiers is not None:
            pa = PoseArray()
            pa.header = header
            for f in r.frontiers:
                p = Pose()
                p.position.x, p.position.y, p.orientation.w = f.goal[0], f.goal[1], 1.0
                pa.poses.append(p)
            self.frontier_pub.publish(pa)
        if r.send is not None:
            goal = MoveBaseGoal()
            goal.target_pose.header.frame_id = header.frame_id
            goal.target_pose.header.stamp = rospy.Time.now()
            goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = r.send.goal
            o = goal.target_pose.pose.orientation
            o.z, o.w = math.sin(r.goal_yaw / 2), math.cos(r.goal_yaw / 2)
            n = self.explore.sent   # this goal's number: its callback names it
            self.goal_handle = self.client.send_goal(goal, transition_cb=lambda h: self._on_transition(n, h))
        return r.over

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
        summary = (f"exploration over: {reason}; {self.explore.sent} goals sent, {self.explore.failed} failed, "
                   f"{rospy.Time.now().to_sec() - t0:.0f} s; map {saved}")
        rospy.loginfo("explore: " + summary)
        self.summary_pub.publish(String(summary))
        self.done_pub.publish(Bool(True))


def main():
    rospy.init_node("explore")
    ExploreNode().run()
    rospy.spin()


if __name__ == "__main__":
    main()
