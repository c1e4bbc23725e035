"""my_summit_localization: the pure-algorithm core of our amcl (no rospy here).

Modules, in the order a filter update runs:
- amcl_config: amcl's ROS parameters (names, defaults, meanings, validation).
- motion_model: amcl's sample motion models (diff, omni, and the -corrected variants).
- likelihood_field: the laser models (likelihood_field, likelihood_field_prob, beam).
- particle_filter: KLD-sampling augmented MCL with low-variance resampling and amcl's
  cluster-based pose estimate.
- amcl_msgs: the amcl node's message conversions (initialpose checks, amcl_pose,
  particlecloud, map->odom).
- spots: the spot recorder's store, the spots YAML schema (config/spots.yaml), the
  atomic write of spots.txt, and load_spots for readers.
"""
