"""ROS plumbing shared by the nodes (see the package docstring)."""
