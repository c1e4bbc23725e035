#!/usr/bin/python3
"""rostest: gmapping (or karto) over the tour of the built-in world makes a map of the building.

Asserts on ground truth (my_summit_mapping.evaluation, as bench_slam_sim.py): map
precision, recall of the walls the laser saw, ATE; and the ROS interface on the way:
latched map_metadata, dynamic_map, ~entropy, tf map -> odom.

Params: ~slam_node (slam_gmapping; slam_karto for mapping_tour_karto.test), ~max_urange
[m] (default: maxUrange of the ~params YAML, gmapping's), ~max_ate [m], ~min_precision,
~min_recall (defaults below). ~entropy is gmapping's alone.

Margins: the benchmark's targets are precision 0.95 / recall 0.90 / ATE 0.05 m. Most
tours reach 0.999 / 0.999 / 0.005 m (bench_slam_sim.py, 5 runs at 3x), but a CI run at
4x gave 0.816 / 0.813 / 0.078 m: some tours still lose the right particle lineage. The
test's margins sit below that tail so that it fails for a broken adapter (a wrong laser
offset, beam order or frame gives precision < 0.5), not for an unlucky draw.
"""
import os
import time
import unittest

import rospy
import rostest
import tf2_ros
import yaml
from nav_msgs.msg import MapMetaData
from nav_msgs.srv import GetMap
from std_msgs.msg import Float64
from summit_xl_sim.sim import LaserParams
from summit_xl_sim.world import World

from my_summit_mapping.tour_recorder import TourRecorder


# Looser than the benchmark's targets (0.95, 0.90, 0.05 m). Five live tours at 4x with the
# motion-model gate on scan-match corrections: ATE 0.004-0.007 m, precision >= 0.998.
# Before it, 2 CI runs of 3 slipped 20 cm along the east corridor (ATE 0.078 m,
# precision 0.82), which these margins catch.
MIN_PRECISION = 0.90
MIN_RECALL = 0.85
MAX_ATE = 0.05         # [m]
TOUR_TIMEOUT = 330.0   # [s wall] the tour is ~170 s simulated, 4x real time


def dump(result, map_msg):
    """Saves what tells a SLAM slip from a gap in the recorded truth (the SLAM trajectory and
    the truth at its stamps, the final map) under ROS_HOME; returns the file's path."""
    import numpy as np
    info = map_msg.info
    path = os.path.join(os.environ.get("ROS_HOME") or os.path.expanduser("~/.ros"), "mapping_tour_dump.npz")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    np.savez_compressed(path, trajectory=result["trajectory"], truth=result["truth"],
                        map=np.asarray(map_msg.data, np.int8).reshape(info.height, info.width),
                        map_origin=(info.origin.position.x, info.origin.position.y), resolution=info.resolution)
    return path


class MappingTour(unittest.TestCase):
    def test_tour_map_quality(self):
        rospy.init_node("mapping_tour_test")
        slam_node = rospy.get_param("~slam_node", "slam_gmapping")
        if rospy.has_param("~max_urange"):
            max_urange = float(rospy.get_param("~max_urange"))
        else:
            with open(rospy.get_param("~params")) as f:
                max_urange = float(yaml.safe_load(f)["maxUrange"])
        max_ate = float(rospy.get_param("~max_ate", MAX_ATE))
        min_precision = float(rospy.get_param("~min_precision", MIN_PRECISION))
        min_recall = float(rospy.get_param("~min_recall", MIN_RECALL))
        world = World.from_yaml(rospy.get_param("~world"))
        recorder = TourRecorder(slam_node)
        entropy = []
        rospy.Subscriber(f"/{slam_node}/entropy", Float64, lambda m: entropy.append(m.data))
        tf_buffer = tf2_ros.Buffer()
        tf2_ros.TransformListener(tf_buffer)

        problem = recorder.wait_done_and_final_map(TOUR_TIMEOUT)
        self.assertIsNone(problem, problem)

        meta = rospy.wait_for_message("/map_metadata", MapMetaData, timeout=10.0)
        self.assertEqual((meta.width, meta.height), (recorder.map_msg.info.width, recorder.map_msg.info.height))
        rospy.wait_for_service("/dynamic_map", timeout=10.0)
        served = rospy.ServiceProxy("/dynamic_map", GetMap)().map
        self.assertEqual(served.header.frame_id, "map")
        self.assertEqual(len(served.data), served.info.width * served.info.height)
        if slam_node == "slam_gmapping":
            self.assertTrue(entropy, "nothing on ~entropy")
        tf_buffer.lookup_transform("map", "odom", rospy.Time(0), rospy.Duration(5.0))

        t0 = time.monotonic()
        r = recorder.evaluate(world, max_urange, LaserParams())
        rospy.loginfo(f"mapping_tour: ATE {r['ate_m']:.3f} m, precision {r['precision']:.3f}, recall "
                      f"{r['recall']:.3f}, {r['processed_scans']} processed scans ({r['scored_poses']} within the "
                      f"recorded truth), {r['occupied_cells']} "
                      f"occupied cells, {r['seen_wall_cells']} seen wall cells "
                      f"(evaluated in {time.monotonic() - t0:.1f} s)")
        if r["ate_m"] > max_ate or r["precision"] < min_precision or r["recall"] < min_recall:
            rospy.logerr(f"mapping_tour: the run's trajectory, truth and map: {dump(r, recorder.map_msg)}")
        self.assertGreater(r["scored_poses"], 50)
        self.assertLessEqual(r["ate_m"], max_ate)
        self.assertGreaterEqual(r["precision"], min_precision)
        self.assertGreaterEqual(r["recall"], min_recall)


if __name__ == "__main__":
    rostest.rosrun("my_summit_mapping", "mapping_tour", MappingTour)
