"""move_base's ROS side that is not the node itself: the costmaps' ROS wrapper
(costmap_ros), the obstacle layers' sensor subscriptions (sensor_hub) and the
dynamic_reconfigure servers (reconfigure). The one subpackage of my_summit_path_planning
that imports rospy; the modules above it stay pure (docs/driving_layer.md)."""
