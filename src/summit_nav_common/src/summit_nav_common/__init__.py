"""What every package of the workspace shares, written once.

Pure (numpy / SciPy / Pillow, no rospy):
  geometry   angles, SE(2) poses (compose, inverse, relative), quaternions
  map_io     map files with ROS map_server's / map_saver's semantics (GridMap)
  distance   exact Euclidean distance fields on grids
  raycast    exact grid ray casting (distance-transform march + cell traversal; numba)
  files      atomic file writes
  jit        numba's njit, or plain Python where numba is missing
ROS plumbing (summit_nav_common.ros):
  tf_wait    a transform at a message's stamp, waited for in wall time
  shutdown   publishing from a node's own thread while rospy shuts down
  map_msgs   nav_msgs/OccupancyGrid <-> GridMap
  costmap_client  a costmap kept whole from its topic and its _updates topic
  reconfigure  dynamic_reconfigure servers that refuse out-of-range values
Test and benchmark helpers (summit_nav_common.testing): launch sessions, profiling,
waits, ground truth, a move_base client, the unit tests' synthetic worlds.
"""
