"""Helpers of the workspace's tests, rostests and benchmarks, written once.

Every package's rostest nodes and benchmark scripts import them from here, as
``from summit_nav_common.testing import waits`` (devel/setup.bash sourced); no test,
script or tool puts another folder on sys.path. rospy is imported only by the modules
that talk to a master.

  roslaunch_session  a roslaunch or roscore on a private master, always stopped; process
                     trees, bounded runs, child benchmark runs (no rospy)
  profile_node       a node under cProfile in every thread (a roslaunch launch-prefix)
                     and a profile's shares by stage (no rospy)
  waits              a topic's latest message, waits in simulated and wall time, /rosout
  ground_truth       the simulator's ground truth in the committed map's frame, the
                     collision count and the driven track
  move_base_client   goals, the move_base action client, waiting for a goal's end,
                     boxes placed around the robot
  scenes             small synthetic worlds of the unit tests: occupancy grids of rooms
                     and corridors, wall segments with an exact ray caster (no rospy)
"""
