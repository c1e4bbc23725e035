"""my_summit_mapping: pure-Python core of the workspace's slam_gmapping replacement.

Modules (no rospy anywhere in this package's importable code):
  slam_config    gmapping's parameters (SlamConfig)
  carmen         CARMEN log reader and synthetic odometry drift
  motion_model   gmapping's odometry sampling motion model
  grid           copy-on-write patched occupancy grid
  scan_matcher   gmapping's hill-climbing scan matcher and likelihood
  rbpf           the Rao-Blackwellized particle filter (RbpfSlam)
  metrics        ATE RMSE and map precision/recall
  evaluation     a SLAM run judged against simulator ground truth (test + benchmark)
  laser_mount    laser mounting checks and beam directions in the base frame
  map_msgs       nav_msgs/OccupancyGrid <-> summit_nav_common.map_io.GridMap (message classes only)
"""
