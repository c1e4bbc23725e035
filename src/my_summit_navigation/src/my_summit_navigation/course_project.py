"""The course project end to end, on a ROS master where the simulator already runs.

Shared by the end-to-end rostest (tests/course_project.test) and `make demo`
(tools/demo.py). It does
what the student does, command for command, with the tour driver and move_base standing
in for the hands on the keyboard:

1. mapping: ``roslaunch my_summit_mapping gmapping.launch sim:=false`` and the tour
   driver (``rosrun summit_xl_sim tour_driver``) through every room;
2. ``rosrun my_summit_mapping map_saver -f DIR/my_map``, then gmapping is stopped
   (Ctrl-C); the robot stays where the tour left it;
3. ``roslaunch my_summit_navigation main.launch map_file:=DIR/my_map.yaml
   initial_pose_x/y/a:=<SLAM's last pose of the robot> spots_file:=DIR/spots.txt`` and
   ``roslaunch my_summit_localization spot_recorder.launch spots_file:=DIR/spots.txt``;
   the robot is driven to each spot (move_base goals where the student uses the
   keyboard), ``rosservice call /save_spot label`` there, then ``label: 'end'``;
4. ``rosservice call /get_coordinates label`` for each spot, in an order that crosses
   rooms; the answer and the pose reached (ground truth) are recorded.

Every launch runs in a process group of its own and is stopped by its PID, also when a
step fails (CourseProject is a context manager). rospy must be initialised in this
process, on simulated time, before the steps run.

The spots are the world's (``spots:`` of the world description, world frame; the caller
reads them with summit_xl_sim.worldgen.world_spots and hands them in). The fresh
map's frame is where the robot stood when mapping began (gmapping's convention), the
simulator's spawn pose: a spot's map-frame pose for driving there is the world pose seen
from the spawn pose. Ground truth is judged in the world frame.
"""
import math
import os
import subprocess
import threading
import time

import rospkg
from summit_nav_common.geometry import (compose, quaternion_to_yaw as yaw_of, relative,  # noqa: F401
                                        wrap_angle as wrap, yaw_to_quaternion_zw)
from summit_nav_common.testing.roslaunch_session import stop_process_tree

SIM_WORLDS = os.path.join(rospkg.RosPack().get_path("summit_xl_sim"), "worlds")
TOUR_FILE = os.path.join(SIM_WORLDS, "course_building_tour.yaml")
WORLD_DESCRIPTION = os.path.join(SIM_WORLDS, "course_building.world.yaml")   # its spots: world_spots
SPOT_ORDER = ("table", "room", "turtle")   # the course's calls: hall -> fetch room table -> centre -> poster
RECORD_ORDER = ("room", "turtle", "table")  # the order the spots are recorded in (course step 2)
EYE_XY_TOL, EYE_YAW_TOL, EYE_TRIES = 0.15, 0.12, 2   # [m], [rad]: "there" by eye (above the goal tolerance)


SKIP_REPORTING_NODES = ("slam_gmapping", "amcl", "move_base")


class StepFailed(RuntimeError):
    """A step of the course project could not be carried out (the message says why)."""


class CourseProject:
    """Runs the course's steps on the current master; see the module doc string.

    workdir: where the map and spots.txt are written and the launch logs go.
    spots: {label: (x [m], y [m], yaw [rad])} in the world frame (world_spots of
    WORLD_DESCRIPTION).
    progress(text): called with one line per event (the caller adds the times).
    """

    def __init__(self, workdir, spots, progress=print, wall_limit=900.0):
        import rospy
        from nav_msgs.msg import Odometry
        from std_msgs.msg import UInt32
        self.workdir = workdir
        os.makedirs(workdir, exist_ok=True)
        self.progress = progress
        self.deadline = time.monotonic() + wall_limit
        self.launches = []            # (name, Popen) in start order
        self.lock = threading.Lock()
        self.truth = []               # (t, x, y, yaw) world frame
        self.collisions = 0
        self.spawn = tuple(float(rospy.get_param("/summit_xl_sim/" + k)) for k in ("x", "y", "yaw"))
        self.spots = dict(spots)
        self._tf = None               # tf2 buffer for amcl_pose (made once navigation starts)
        self._subs = [rospy.Subscriber("/base_pose_ground_truth", Odometry, self._on_truth, queue_size=50),
                      rospy.Subscriber("/collisions", UInt32, self._on_coll, queue_size=5)]
        # scans each node lost because it fell behind (its latched ~scans_skipped)
        self.scans_skipped = {node: 0 for node in SKIP_REPORTING_NODES}
        self._subs += [rospy.Subscriber(f"/{node}/scans_skipped", UInt32, self._on_skipped, node, queue_size=5)
                       for node in SKIP_REPORTING_NODES]

    # ----------------------------------------------------------------- plumbing
    def _on_truth(self, msg):
        p = msg.pose.pose
        with self.lock:
            self.truth.append((msg.header.stamp.to_sec(), p.position.x, p.position.y, yaw_of(p.orientation)))

    def _on_coll(self, msg):
        with self.lock:
            self.collisions = max(self.collisions, int(msg.data))

    def _on_skipped(self, msg, node):
        with self.lock:
            self.scans_skipped[node] = max(self.scans_skipped[node], int(msg.data))

    def skipped_summary(self):
        """'amcl 0, slam_gmapping 0, move_base 0': scans each node lost so far."""
        with self.lock:
            return ", ".join(f"{node} {n}" for node, n in self.scans_skipped.items())

    def pose(self):
        """The robot's latest ground-truth pose (x, y, yaw) in the world frame."""
        with self.lock:
            return self.truth[-1][1:] if self.truth else None

    def start(self, name, args):
        """Start `roslaunch`/`rosrun` args in its own process group, output to workdir/name.log."""
        log = open(os.path.join(self.workdir, name + ".log"), "w")
        proc = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                                env=dict(os.environ))
        log.close()
        self.launches.append((name, proc))
        return proc

    def stop(self, name):
        """Stop one started launch (SIGINT, then SIGKILL of its tree), by its PID."""
        for n, proc in list(self.launches):
            if n == name:
                stop_process_tree(proc, grace=15.0)
                self.launches.remove((n, proc))

    def alive(self, name):
        """True while the started launch `name` runs."""
        return any(n == name and proc.poll() is None for n, proc in self.launches)

    def close(self):
        for name, proc in reversed(self.launches):
            stop_process_tree(proc, grace=15.0)
        self.launches = []
        for s in self._subs:
            s.unregister()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def check(self, what):
        """StepFailed if a started launch died or the wall-time budget is spent."""
        for name, proc in self.launches:
            if proc.poll() is not None:
                raise StepFailed(f"{name} ended (exit {proc.returncode}) while {what}; see "
                                 f"{os.path.join(self.workdir, name + '.log')}")
        if time.monotonic() > self.deadline:
            raise StepFailed(f"out of wall time while {what}")

    def wait(self, predicate, what, timeout_wall):
        end = min(self.deadline, time.monotonic() + timeout_wall)
        while not predicate():
            self.check(what)
            if time.monotonic() > end:
                raise StepFailed(f"timed out after {timeout_wall:.0f} s (wall) {what}")
            time.sleep(0.05)

    def spot_in_map(self, label):
        """Where the spot is in the fresh map's frame (its origin: the spawn pose)."""
        return relative(self.spawn, self.spots[label])

    def error_to(self, label):
        """(xy [m], yaw [rad]) ground-truth error of the robot to the world spot."""
        x, y, yaw = self.pose()
        sx, sy, syaw = self.spots[label]
        return math.hypot(x - sx, y - sy), abs(wrap(yaw - syaw))

    # ----------------------------------------------------------------- steps
    def map_building(self, recorder_factory):
        """Step 1: gmapping.launch + the tour driver; returns the TourRecorder (ground
        truth, the final map and SLAM trajectory) once the final map is in."""
        import rospy
        recorder = recorder_factory()
        self.start("gmapping", ["roslaunch", "my_summit_mapping", "gmapping.launch", "sim:=false"])
        self.wait(lambda: self._has_publisher("/map"), "waiting for slam_gmapping to come up", 60)
        t0 = rospy.Time.now().to_sec()
        self.start("tour_driver", ["rosrun", "summit_xl_sim", "tour_driver", f"_waypoints_file:={TOUR_FILE}"])
        self.progress("slam_gmapping up; the tour driver takes the robot through every room")
        rooms_seen = set()
        while recorder.done_time is None:
            self.check("the tour was driven")
            p = self.pose()
            room = room_of(p[0], p[1]) if p else None
            if room and room not in rooms_seen:
                rooms_seen.add(room)
                self.progress(f"mapping: entered the {room} ({recorder.map_count} maps published so far)")
            time.sleep(0.1)
        self.progress(f"tour done after {rospy.Time.now().to_sec() - t0:.0f} s (sim), {self.collisions} "
                      "collisions; waiting for slam_gmapping's final map")
        problem = recorder.wait_done_and_final_map(min(120.0, self.deadline - time.monotonic()),
                                                   lambda: self.alive("gmapping"))
        if problem:
            raise StepFailed(f"mapping: {problem}")
        self.stop("tour_driver")
        return recorder

    def save_map(self, base):
        """Step 1's end: map_saver -f base while gmapping runs; then gmapping is stopped.

        Returns SLAM's last pose of the robot in the map frame (map -> base_footprint),
        the initial pose for amcl."""
        import rospy
        import tf2_ros
        buf = tf2_ros.Buffer()
        listener = tf2_ros.TransformListener(buf)
        saver = subprocess.run(["rosrun", "my_summit_mapping", "map_saver", "-f", base], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, timeout=120)
        if saver.returncode != 0 or not os.path.exists(base + ".yaml"):
            raise StepFailed(f"map_saver -f {base} failed: {saver.stdout[-1500:]}")
        self.progress(f"map saved with map_saver -f {base}")
        end = time.monotonic() + 30.0
        while True:
            try:
                tf = buf.lookup_transform("map", "base_footprint", rospy.Time(0), rospy.Duration(1.0))
                break
            except (tf2_ros.LookupException, tf2_ros.ExtrapolationException, tf2_ros.ConnectivityException) as e:
                if time.monotonic() > end:
                    raise StepFailed(f"no map -> base_footprint from slam_gmapping: {e}") from None
        listener.unregister()
        t = tf.transform
        initial = (t.translation.x, t.translation.y, yaw_of(t.rotation))
        self.stop("gmapping")   # the student's Ctrl-C: its map -> odom ends here
        self.progress(f"slam_gmapping stopped; its last pose of the robot: ({initial[0]:.2f}, {initial[1]:.2f}, "
                      f"{math.degrees(initial[2]):.0f} deg) in the map frame")
        return initial

    def start_navigation(self, map_yaml, initial, spots_file):
        """Step 2/3/4's launches on the saved map: main.launch (map_server, amcl,
        move_base, /get_coordinates) and the spot recorder."""
        import rospy
        from move_base_msgs.msg import MoveBaseAction
        from summit_nav_common.ros.action_client import SimpleActionClient
        self.start("main", ["roslaunch", "my_summit_navigation", "main.launch", "sim:=false", f"map_file:={map_yaml}",
                            f"initial_pose_x:={initial[0]:.4f}", f"initial_pose_y:={initial[1]:.4f}",
                            f"initial_pose_a:={initial[2]:.4f}", f"spots_file:={spots_file}"])
        self.start("spot_recorder", ["roslaunch", "my_summit_localization", "spot_recorder.launch",
                                     f"spots_file:={spots_file}"])
        self.client = SimpleActionClient("move_base", MoveBaseAction)
        import tf2_ros
        self._tf = tf2_ros.Buffer()
        self._tf_listener = tf2_ros.TransformListener(self._tf)
        self.wait(lambda: self.client.wait_for_server(rospy.Duration(0.2)), "waiting for move_base", 120)
        for srv in ("/save_spot", "/get_coordinates"):
            self.wait(lambda: self._has_service(srv), f"waiting for {srv}", 60)
        self.progress("map_server, amcl, move_base, /save_spot and /get_coordinates up on the saved map")

    def drive_to(self, label, timeout_wall=240.0):
        """Bring the robot to a spot as the student does in step 2: by eye, i.e. by ground
        truth. A move_base goal at the spot's nominal map pose first; the fresh map is
        slightly distorted (SLAM error), so while the robot stands more than
        EYE_XY_TOL / EYE_YAW_TOL from the real spot it gets a corrected goal (its amcl
        pose moved by what ground truth says is still missing), at most EYE_TRIES times.
        Returns (actionlib state, result text) of the last goal."""
        state, text = self.drive_to_pose(label, self.spot_in_map(label), timeout_wall)
        for _ in range(EYE_TRIES):
            exy, eyaw = self.error_to(label)
            if state != 3 or (exy <= EYE_XY_TOL and eyaw <= EYE_YAW_TOL):
                break
            missing = relative(self.pose(), self.spots[label])   # the spot seen from the robot
            self.progress(f"'{label}': {exy:.2f} m / {math.degrees(eyaw):.0f} deg off by eye: closer")
            state, text = self.drive_to_pose(label, compose(self.amcl_pose(), missing), timeout_wall)
        return state, text

    def amcl_pose(self, timeout_wall=10.0):
        """The robot's pose in the map frame as the stack believes it (tf map ->
        base_footprint: amcl's map -> odom and the odometry)."""
        import rospy
        import tf2_ros
        if self._tf is None:
            self._tf = tf2_ros.Buffer()
            self._tf_listener = tf2_ros.TransformListener(self._tf)
        t = self._tf.lookup_transform("map", "base_footprint", rospy.Time(0), rospy.Duration(timeout_wall)).transform
        return (t.translation.x, t.translation.y, yaw_of(t.rotation))

    def drive_home(self, timeout_wall=240.0):
        """Drive back to where mapping began (the map frame's origin, in the main hall)."""
        return self.drive_to_pose("the start", (0.0, 0.0, 0.0), timeout_wall)

    def drive_to_pose(self, label, pose, timeout_wall=240.0):
        """A move_base goal at pose (x, y, yaw) in the map frame; waits for its end.
        Returns (actionlib state, result text)."""
        import rospy
        from move_base_msgs.msg import MoveBaseGoal
        x, y, yaw = pose
        goal = MoveBaseGoal()
        goal.target_pose.header.frame_id = "map"
        goal.target_pose.header.stamp = rospy.Time.now()
        goal.target_pose.pose.position.x, goal.target_pose.pose.position.y = x, y
        goal.target_pose.pose.orientation.z, goal.target_pose.pose.orientation.w = yaw_to_quaternion_zw(yaw)
        self.client.send_goal(goal)
        end = time.monotonic() + timeout_wall
        while not self.client.wait_for_result(rospy.Duration(0.1)):
            try:
                self.check(f"driving to '{label}'")
                if time.monotonic() > end:
                    raise StepFailed(f"'{label}' not reached within {timeout_wall:.0f} s (wall)")
            except StepFailed:
                self.client.cancel_goal()
                raise
        return self.client.get_state(), self.client.get_goal_status_text()

    def call(self, service, label, timeout_wall=300.0):
        """rosservice call service "label: '...'" (both services take MyServiceMessage);
        returns the response. Bounded by timeout_wall (the call itself runs in a thread)."""
        import rospy
        from my_summit_navigation.srv import MyServiceMessage
        proxy = rospy.ServiceProxy(service, MyServiceMessage)
        box = {}

        def run():
            try:
                box["resp"] = proxy(label)
            except Exception as e:  # a dead server, a broken connection
                box["error"] = e

        th = threading.Thread(target=run, daemon=True)
        th.start()
        end = time.monotonic() + timeout_wall
        while th.is_alive():
            self.check(f"calling {service} '{label}'")
            if time.monotonic() > end:
                raise StepFailed(f"{service} '{label}' did not answer within {timeout_wall:.0f} s (wall)")
            th.join(0.1)
        if "error" in box:
            raise StepFailed(f"{service} '{label}': {box['error']}")
        return box["resp"]

    @staticmethod
    def _has_publisher(topic):
        import rospy
        try:
            return any(t == topic for t, _ in rospy.get_published_topics())
        except Exception:
            return False

    @staticmethod
    def _has_service(name):
        import rosservice
        try:
            return name in rosservice.get_service_list()
        except Exception:
            return False


ROOMS = [  # (name, xmin, ymin, xmax, ymax) of the built-in building, world frame [m]
    ("main hall", 0, 0, 12, 14), ("room 1", 12, 7, 16, 14),
    ("room 2", 16, 7, 20, 14), ("fetch room", 12, 0, 20, 7)]


def room_of(x, y):
    """Name of the built-in building's room containing (x, y), or None."""
    for name, x0, y0, x1, y1 in ROOMS:
        if x0 <= x < x1 and y0 <= y < y1:
            return name
    return None
