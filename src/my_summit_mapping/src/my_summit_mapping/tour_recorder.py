"""A simulated mapping run recorded from its topics and judged by ground truth.

Shared by the mapping benchmark (scripts/bench_slam_sim.py), the mapping and course
project rostests, the exploration benchmark and `make demo`: TourRecorder keeps the
simulator's ground truth, the tour driver's end, the latest map and the SLAM node's
trajectory; evaluate() hands them to my_summit_mapping.evaluation; write_png draws the
judged run. rospy is imported by the methods that need it (call after rospy.init_node).
"""
import threading
import time

import numpy as np

FINAL_MAP_GRACE = 30.0  # [s sim] after the tour for the last map (map_update_interval 5 s)


class TourRecorder:
    """Ground truth, the tour's end, the latest map and SLAM trajectory, from ROS topics.

    slam_node: the SLAM node whose ~trajectory is recorded (slam_gmapping or slam_karto).
    trajectory_from_tf: for a node without ~trajectory (the real slam_karto): the
    trajectory is map -> base_footprint sampled from tf every TF_SAMPLE_PERIOD (the online
    estimate, not the optimized one).
    """

    TF_SAMPLE_PERIOD = 0.2   # [s sim]

    def __init__(self, slam_node="slam_gmapping", trajectory_from_tf=False):
        import rospy
        from nav_msgs.msg import OccupancyGrid, Odometry, Path
        from rospy.numpy_msg import numpy_msg
        from std_msgs.msg import Bool
        self.lock = threading.Lock()
        self.truth = []             # (t [s], x [m], y [m], yaw [rad])
        self.done_time = None       # sim time the tour driver said done [s]
        self.map_msg = None
        self.path_msg = None
        self.map_count = 0
        self.subs = [
            rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on_truth, queue_size=200),
            rospy.Subscriber("/tour_driver/done", Bool, self._on_done, queue_size=1),
            rospy.Subscriber("/map", numpy_msg(OccupancyGrid), self._on_map, queue_size=1,
                             buff_size=2 ** 24)]
        if trajectory_from_tf:
            import tf2_ros
            self._tf_buffer = tf2_ros.Buffer()
            self._tf_listener = tf2_ros.TransformListener(self._tf_buffer)
            self._tf_poses = []
            self._tf_timer = rospy.Timer(rospy.Duration(self.TF_SAMPLE_PERIOD), self._sample_tf)
        else:
            self.subs.append(rospy.Subscriber(f"/{slam_node}/trajectory", Path, self._on_path, queue_size=1,
                                              buff_size=2 ** 22))

    def _sample_tf(self, _event):
        import rospy
        import tf2_ros
        from geometry_msgs.msg import PoseStamped
        from nav_msgs.msg import Path
        try:
            t = self._tf_buffer.lookup_transform("map", "base_footprint", rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException):
            return
        if self._tf_poses and t.header.stamp <= self._tf_poses[-1].header.stamp:
            return
        ps = PoseStamped()
        ps.header = t.header
        ps.pose.position.x, ps.pose.position.y = t.transform.translation.x, t.transform.translation.y
        ps.pose.orientation = t.transform.rotation
        self._tf_poses.append(ps)
        path = Path()
        path.header = t.header
        path.poses = list(self._tf_poses)
        with self.lock:
            self.path_msg = path

    def _on_truth(self, msg):
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        yaw = np.arctan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
        with self.lock:
            self.truth.append((msg.header.stamp.to_sec(), p.x, p.y, yaw))

    def _on_done(self, msg):
        import rospy
        if msg.data and self.done_time is None:
            self.done_time = rospy.Time.now().to_sec()
            assert self.done_time < 1e6, "rospy is not on simulated time (/use_sim_time)"

    def _on_map(self, msg):
        with self.lock:
            self.map_msg = msg
            self.map_count += 1

    def _on_path(self, msg):
        with self.lock:
            self.path_msg = msg

    def wait_done_and_final_map(self, timeout_wall, alive=lambda: True):
        """Block until the tour is done and a map and trajectory stamped after it arrived.

        Returns None or why it failed (timeout, launch died)."""
        import rospy
        end = time.monotonic() + timeout_wall
        while time.monotonic() < end and not rospy.is_shutdown():
            if not alive():
                return "the launch ended before the tour was done"
            with self.lock:
                done = self.done_time
                m, p = self.map_msg, self.path_msg
            if done is not None and m is not None and p is not None and \
                    m.header.stamp.to_sec() > done and p.header.stamp.to_sec() > done:
                return None
            if done is not None and rospy.Time.now().to_sec() > done + FINAL_MAP_GRACE:
                return (f"no map and trajectory published within {FINAL_MAP_GRACE} s (sim) after the tour "
                        f"(done at {done:.1f} s; {self.map_count} maps, last stamped "
                        f"{m.header.stamp.to_sec() if m else None}; trajectory stamped "
                        f"{p.header.stamp.to_sec() if p else None})")
            time.sleep(0.1)
        return f"tour not done within {timeout_wall} s (wall)"

    def evaluate(self, world, max_urange, laser):
        """my_summit_mapping.evaluation.evaluate of the recorded run in `world` (the
        simulator's World), with the simulated laser `laser` (its mount and angles(),
        summit_xl_sim.sim.LaserParams) and the SLAM node's maxUrange [m]."""
        from my_summit_mapping import evaluation
        with self.lock:
            truth = np.array(self.truth)
            m, p = self.map_msg, self.path_msg
        order = np.argsort(truth[:, 0], kind="stable")
        truth = truth[order]
        traj = np.array([(ps.pose.position.x, ps.pose.position.y,
                          2 * np.arctan2(ps.pose.orientation.z, ps.pose.orientation.w)) for ps in p.poses])
        times = np.array([ps.header.stamp.to_sec() for ps in p.poses])
        info = m.info
        grid = (np.asarray(m.data, np.int8), info.width, info.height, info.resolution,
                info.origin.position.x, info.origin.position.y)
        result = evaluation.evaluate(traj, times, truth[:, 0], truth[:, 1:], grid, world,
                                     laser.mount, laser.angles(), max_urange)
        inside = evaluation.within_span(times, truth[:, 0])
        result.update(trajectory=traj[inside],
                      truth=evaluation.interpolate_poses(times[inside], truth[:, 0], truth[:, 1:]),
                      processed_scans=len(traj))
        return result


def write_png(result, path, world):
    """The judged run (TourRecorder.evaluate's result) as a world-frame picture: true
    walls grey, seen walls not mapped blue, SLAM occupied cells black (near a wall) or red
    (not), ground truth green, SLAM trajectory red."""
    import cv2
    walls, occ, seen = world.walls, result["map_occupied"], result["seen_walls"]
    img = np.full(walls.shape + (3,), 255, np.uint8)
    img[walls] = (200, 200, 200)
    near = cv2.dilate(occ.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    img[seen & ~near] = (255, 0, 0)
    near_wall = cv2.dilate(walls.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    img[occ & near_wall] = (0, 0, 0)
    img[occ & ~near_wall] = (0, 0, 255)
    rot_yaw, tx, ty = result["alignment"]
    c, s = np.cos(rot_yaw), np.sin(rot_yaw)
    for poses, colour in ((result["truth"], (0, 160, 0)), (result["trajectory"], (0, 0, 255))):
        xy = poses[:, :2]
        if poses is result["trajectory"]:
            xy = xy @ np.array([[c, -s], [s, c]]).T + (tx, ty)
        gx, gy = world.to_grid(xy[:, 0], xy[:, 1])
        pts = np.column_stack((gx, gy)).round().astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(img, [pts], False, colour, 1)
    img = np.flipud(img)
    scale = 2
    cv2.imwrite(path, cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST))
