"""my_summit_path_planning: the pure-algorithm core of our move_base replacement.

No rospy here (SPEC.md): costmaps (costmap_2d), the NavFn global planner (navfn), the
DWA local planner (dwa_local_planner / base_local_planner), recoveries (clear_costmap,
rotate_recovery) and the typed parameter configs. The move_base node is a thin adapter.
"""
