"""A CARMEN corrected log as a rosbag, for running the live slam_gmapping node on real data.

What the bag holds, per FLASER line k (bag time = message stamp = the scan's time):
  /tf        odom -> base_link: the drifted odometry at the scan (carmen.make_drifted_odometry,
             Probabilistic Robotics' rot1 / trans / rot2 model, seeded), written before the scan
  /scan      sensor_msgs/LaserScan in frame base_laser: the front laser's beams from -90 deg
             (carmen.beam_angles: 180 beams 1 deg apart, or 181 including +90 deg); the
             log's "no return" reading (its largest, 81.83 m in Intel) as +inf, as REP 117
             says for a reading with no return, range_max = that reading, range_min 0
  /reference_pose  geometry_msgs/PoseStamped in frame "reference": the corrected pose
and once, latched, /tf_static base_link -> base_laser (the log's robot_frontlaser_offset
ahead, else identity), STATIC_LEAD before the first scan so that a node has the laser's
mount when the first scan comes. Stamps are the FLASER ipc timestamps made strictly increasing
(carmen.monotonic_stamps): the Intel log goes back in time four times.

`bag_scans` is the pure part (numpy only): the arrays, from a CarmenLog and a seed;
`as_received` rounds them as the messages do (float32 ranges and LaserScan angles, yaw
through a quaternion, stamps in whole nanoseconds), so that a replay without ROS feeds
the filter exactly what the live node gets from the bag. `write_bag` / `read_bag` turn
them into a bag and back (rosbag and the message classes are imported there, so the pure
part is usable without ROS).
"""
import copy
from dataclasses import dataclass, replace

import numpy as np
from summit_nav_common.geometry import quaternion_to_yaw, yaw_of_quaternion, yaw_to_quaternion_zw

from . import carmen

ODOM_FRAME = "odom"
BASE_FRAME = "base_link"
LASER_FRAME = "base_laser"
REFERENCE_FRAME = "reference"
SCAN_TOPIC = "/scan"
REFERENCE_TOPIC = "/reference_pose"
RANGE_MIN = 0.0          # CARMEN logs give no minimum; gmapping's reader has none either [m]
MIN_STAMP_GAP = 0.01     # a scan stamp is at least this after the one before [s]
STATIC_LEAD = 1.0        # /tf_static is this long before the first scan [s]
ODOM_SEED_OFFSET = 1000  # drift seed = seed + this, so drift and filter noise differ (as
                         # bench_slam_carmen.py)


@dataclass
class BagScans:
    """The content of a CARMEN bag; arrays have one row per scan."""
    stamps: np.ndarray       # (M,) scan times [s], strictly increasing
    ranges: np.ndarray       # (M, n) ranges [m], +inf where the laser had no return
    angle_min: float         # first beam [rad] in base_laser
    angle_increment: float   # between beams [rad]
    range_max: float         # the log's no-return reading [m]
    odometry: np.ndarray     # (M, 3) drifted odom -> base_link [m, m, rad]
    reference: np.ndarray    # (M, 3) corrected poses [m, m, rad]
    laser_offset: float      # base_link -> base_laser along x [m]
    seed: int                # the seed the drift was drawn from (ODOM_SEED_OFFSET added)
    stamps_moved: int        # how many stamps monotonic_stamps moved


def bag_scans(log: carmen.CarmenLog, seed: int) -> BagScans:
    """The bag's content for `log`, the drift drawn from np.random.default_rng(seed +
    ODOM_SEED_OFFSET) with carmen's default drift noise."""
    no_return = log.no_return_range
    ranges = np.where(log.ranges >= no_return, np.inf, log.ranges)
    stamps = carmen.monotonic_stamps(log.timestamps, MIN_STAMP_GAP)
    odom = carmen.make_drifted_odometry(log.poses, np.random.default_rng(seed + ODOM_SEED_OFFSET))
    return BagScans(stamps=stamps, ranges=ranges, angle_min=float(log.angles[0]),
                    angle_increment=float(log.angles[1] - log.angles[0]), range_max=no_return,
                    odometry=odom, reference=log.poses.copy(), laser_offset=log.laser_offset,
                    seed=seed, stamps_moved=int(np.sum(stamps != log.timestamps)))


def as_received(scans: BagScans) -> BagScans:
    """`scans` as read back from their bag (read_bag) and as the live node gets them:
    ranges, angle_min, angle_increment and range_max rounded to float32 (LaserScan's
    fields), every yaw through the quaternion written for it, stamps truncated to whole
    nanoseconds as rospy.Time.from_sec does. The filter is chaotic: a replay fed the
    float64 values of the log drifts away from the live run within a few hundred updates."""
    def via_quaternion(poses):
        out = np.array(poses, float)
        out[:, 2] = [yaw_of_quaternion(0.0, 0.0, *yaw_to_quaternion_zw(float(t))) for t in out[:, 2]]
        return out

    nsec = np.array([int(t) * 1000000000 + int((t - int(t)) * 1000000000) for t in map(float, scans.stamps)])
    f32 = lambda v: float(np.float32(v))  # noqa: E731
    return replace(scans, stamps=nsec * 1e-9,
                   ranges=scans.ranges.astype(np.float32).astype(float), angle_min=f32(scans.angle_min),
                   angle_increment=f32(scans.angle_increment), range_max=f32(scans.range_max),
                   odometry=via_quaternion(scans.odometry), reference=via_quaternion(scans.reference))


def _yaw_quaternion(q, yaw):
    """Set quaternion message q to a rotation by yaw [rad] about z."""
    q.x = q.y = 0.0
    q.z, q.w = yaw_to_quaternion_zw(yaw)


def write_bag(scans: BagScans, path: str, mount_in_tf: bool = False) -> None:
    """Write `scans` to the rosbag `path` (uncompressed); same scans -> same bytes.

    mount_in_tf: also put base_link -> base_laser into every /tf message, stamped as it, for
    readers that take /tf only (the real gmapping's slam_gmapping_replay)."""
    import rosbag
    import rospy
    from geometry_msgs.msg import PoseStamped, TransformStamped
    from sensor_msgs.msg import LaserScan
    from tf2_msgs.msg import TFMessage

    n = scans.ranges.shape[1]
    t0 = rospy.Time.from_sec(float(scans.stamps[0]) - STATIC_LEAD)
    with rosbag.Bag(path, "w") as bag:
        mount = TransformStamped()
        mount.header.stamp = t0
        mount.header.frame_id, mount.child_frame_id = BASE_FRAME, LASER_FRAME
        mount.transform.translation.x = float(scans.laser_offset)
        mount.transform.rotation.w = 1.0
        static = TFMessage(transforms=[mount])
        bag.write("/tf_static", static, t0, connection_header={
            "latching": "1", "topic": "/tf_static", "type": static._type,
            "md5sum": static._md5sum, "message_definition": static._full_text})
        for k, t in enumerate(scans.stamps):
            stamp = rospy.Time.from_sec(float(t))
            x, y, yaw = (float(v) for v in scans.odometry[k])
            tf = TransformStamped()
            tf.header.stamp = stamp
            tf.header.frame_id, tf.child_frame_id = ODOM_FRAME, BASE_FRAME
            tf.transform.translation.x, tf.transform.translation.y = x, y
            _yaw_quaternion(tf.transform.rotation, yaw)
            transforms = [tf]
            if mount_in_tf:
                moved = TransformStamped(header=copy.deepcopy(mount.header), child_frame_id=LASER_FRAME,
                                         transform=mount.transform)
                moved.header.stamp = stamp
                transforms.append(moved)
            bag.write("/tf", TFMessage(transforms=transforms), stamp)
            scan = LaserScan()
            scan.header.seq = k
            scan.header.stamp = stamp
            scan.header.frame_id = LASER_FRAME
            scan.angle_min = scans.angle_min
            scan.angle_increment = scans.angle_increment
            scan.angle_max = scans.angle_min + (n - 1) * scans.angle_increment
            scan.range_min, scan.range_max = RANGE_MIN, float(scans.range_max)
            scan.ranges = [float(r) for r in scans.ranges[k]]
            bag.write(SCAN_TOPIC, scan, stamp)
            ref = PoseStamped()
            ref.header.seq = k
            ref.header.stamp = stamp
            ref.header.frame_id = REFERENCE_FRAME
            rx, ry, ryaw = (float(v) for v in scans.reference[k])
            ref.pose.position.x, ref.pose.position.y = rx, ry
            _yaw_quaternion(ref.pose.orientation, ryaw)
            bag.write(REFERENCE_TOPIC, ref, stamp)


def read_bag(path: str) -> BagScans:
    """The scans, odometry and reference of a bag written by `write_bag` (seed -1: a bag
    does not record it). ValueError naming the file when a topic is missing or the scans
    have no odometry at their stamps."""
    import rosbag

    stamps, ranges, ref, odom_at = [], [], [], {}
    scan0 = None
    offset = 0.0
    with rosbag.Bag(path) as bag:
        for topic, msg, _t in bag.read_messages(topics=["/tf", "/tf_static", SCAN_TOPIC, REFERENCE_TOPIC]):
            if topic in ("/tf", "/tf_static"):
                for tf in msg.transforms:
                    if (tf.header.frame_id, tf.child_frame_id) == (ODOM_FRAME, BASE_FRAME):
                        p = tf.transform.translation
                        odom_at[tf.header.stamp.to_nsec()] = (p.x, p.y, quaternion_to_yaw(tf.transform.rotation))
                    elif (tf.header.frame_id, tf.child_frame_id) == (BASE_FRAME, LASER_FRAME):
                        offset = tf.transform.translation.x
            elif topic == SCAN_TOPIC:
                scan0 = scan0 or msg
                stamps.append(msg.header.stamp.to_nsec())
                ranges.append(np.asarray(msg.ranges, float))
            else:
                p = msg.pose.position
                ref.append((p.x, p.y, quaternion_to_yaw(msg.pose.orientation)))
    if not stamps or len(ref) != len(stamps):
        raise ValueError(f"{path}: not a CARMEN bag ({len(stamps)} scans on {SCAN_TOPIC}, "
                         f"{len(ref)} poses on {REFERENCE_TOPIC})")
    missing = [s for s in stamps if s not in odom_at]
    if missing:
        raise ValueError(f"{path}: {len(missing)} scans have no {ODOM_FRAME} -> {BASE_FRAME} tf at their stamp")
    return BagScans(stamps=np.array(stamps) * 1e-9, ranges=np.vstack(ranges), angle_min=scan0.angle_min,
                    angle_increment=scan0.angle_increment, range_max=scan0.range_max,
                    odometry=np.array([odom_at[s] for s in stamps]), reference=np.array(ref),
                    laser_offset=offset, seed=-1, stamps_moved=0)
