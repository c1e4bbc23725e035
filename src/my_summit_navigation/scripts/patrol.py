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
  param ~stuck_timeout (float [s], default 30; ~movement_timeout is the same): no 0.1 m of
        progress toward the goal for this long: the goal is canceled and retried
  param ~home (label, or [x, y, yaw_deg]; default: where the robot stood at the start)
  param ~dock (label, or [x, y, yaw_deg]; default none): where to charge when the battery
        is low; the battery parameters are cruise_node's (~battery_topic, ~low_battery,
        ~resume_battery, ~critical_battery, ~battery_timeout, ~charge_start_timeout)
  srv   ~return_home (std_srvs/Trigger): cancel the current goal, drive home, stop
  topic ~summary (std_msgs/String, latched): the summary line when the patrol ends

Logs one line per goal (reached / retrying / SKIPPED with the reason) and a summary:
reached, retried, skipped, time. The same cruise as auto_navigator: the decisions are
my_summit_navigation.cruise, the ROS side my_summit_navigation.cruise_node.
"""
import rospkg
import rospy
import tf2_ros
from std_srvs.srv import Trigger, TriggerResponse

from my_summit_localization.spots import Spot
from summit_nav_common.geometry import quaternion_to_yaw
from my_summit_navigation import cruise as cr
from my_summit_navigation.cruise_node import CruiseNode, read_common_params
from my_summit_navigation.spot_goals import SpotBook


def stop_param(name, book, frame):
    """A Stop from ~name (a label of book, or [x, y, yaw_deg]); None when unset."""
    value = rospy.get_param(name, None)
    if value is None:
        return None
    stop = cr.build_stops(labels=[value], book=book, frame=frame)[0] if isinstance(value, str) \
        else cr.build_stops(poses=[value], frame=frame)[0]
    if stop.error:
        raise ValueError(f"{rospy.resolve_name(name)}: {stop.error}")
    return cr.Stop(name.lstrip("~"), stop.spot, stop.frame)


class Patrol:
    def __init__(self):
        params = read_common_params(stuck_timeout_alias=True)
        self.frame = params["frame"]
        default_spots = rospkg.RosPack().get_path("my_summit_localization") + "/config/spots.yaml"
        self.book = SpotBook(rospy.get_param("~spots_file", default_spots))
        labels, poses = rospy.get_param("~labels", None), rospy.get_param("~poses", None)
        if labels is None and poses is None:
            raise ValueError("give ~labels (spots of ~spots_file) or ~poses ([x, y, yaw_deg] in ~frame_id)")
        if labels is not None and not isinstance(labels, list):
            labels = [labels]
        stops = cr.build_stops(labels=labels, book=self.book, frame=self.frame) if labels is not None \
            else cr.build_stops(poses=poses, frame=self.frame)
        dock = stop_param("~dock", self.book, self.frame)
        self.node = CruiseNode(stops, int(rospy.get_param("~rounds", 1)), dock, params, prefix="patrol round",
                               summary_text=lambda cruise, summary: cruise.log.summary(cruise.lap, summary["time_s"]))
        self.tf = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf)
        rospy.Service("~return_home", Trigger, self._on_return_home)

    def _on_return_home(self, _req):
        return TriggerResponse(*self.node.request_return_home())

    def start_pose(self):
        t = self.tf.lookup_transform(self.frame, "base_footprint", rospy.Time(0), rospy.Duration(30.0)).transform
        return Spot.from_xy_yaw(t.translation.x, t.translation.y, quaternion_to_yaw(t.rotation))

    def resolve_home(self):
        """~home, or where the robot stands once move_base is up."""
        return stop_param("~home", self.book, self.frame) or cr.Stop("home", self.start_pose(), self.frame)

    def run(self):
        self.node.run(home=self.resolve_home)


def main():
    rospy.init_node("patrol")
    try:
        patrol = Patrol()
        patrol.run()
    except (ValueError, RuntimeError, tf2_ros.TransformException) as e:
        rospy.logerr(f"patrol: {e}")
        raise SystemExit(1)
    patrol.node.spin()   # keep ~summary, ~return_home and the diagnostics up until shut down


if __name__ == "__main__":
    main()
