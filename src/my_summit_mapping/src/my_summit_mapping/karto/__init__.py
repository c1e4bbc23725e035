"""Graph SLAM in the manner of open_karto + SPA (slam_karto's core), without ROS.

Modules, in the order a scan goes through them: correlative_matcher (Olson 2009 scan
matching), pose_graph (nodes and edges), loop_closure (candidate chains and their
validation), optimizer (sparse Levenberg-Marquardt on SE(2)), render (occupancy grid),
serialize (the graph and its scans in one file), mapper (the orchestrator: KartoMapper).
"""
