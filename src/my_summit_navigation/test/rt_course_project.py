#!/usr/bin/python3
"""rostest (tests/course_project.test): the course project end to end, by ground truth.

The steps are my_summit_navigation.course_project's (shared with `make demo`): map the building with
slam_gmapping and the tour driver, save the map with map_saver, stop gmapping, start
main.launch on the saved map with SLAM's last pose as amcl's initial pose, drive to the
three spots and record each with /save_spot, then 'end'; drive back to the hall; call
/get_coordinates for table, room, turtle. Asserts: the saved map resembles the building
(precision/recall against the true walls), every goal and call succeeds, the robot
stands within ~xy_tolerance / ~yaw_tolerance of each world spot after its
/get_coordinates call, the spots file holds the three labels, zero collisions.

Load, as a student's Gazebo or browser beside the stack would put on a 2-core laptop
(one core kept busy by another process), in one of two forms:
- ~one_core (the default in tests/course_project.test): the whole rostest (simulator,
  nodes, roslaunch, this node) is confined to one CPU, so the stack can never use more
  than one core; every process of the run must still be confined at the end.
- ~cpu_hog: a process spins for the whole run beside an unconfined stack; it must still
  be running at the end and have used at least ~cpu_hog_min_share of one core.
Confinement is the stricter of the two (with a hog, the scheduler still gives a stack of
several busy processes more than one core), and it leaves the other core to the rest of
`make test` instead of burning it.
"""
import contextlib
import math
import os
import subprocess
import sys
import time
import unittest

import rospkg
import rospy
import rostest
import yaml

from summit_nav_common.testing import roslaunch_session as rs
from summit_xl_sim.sim import LaserParams
from summit_xl_sim.worldgen import world_spots

from my_summit_mapping.tour_recorder import TourRecorder
from my_summit_navigation import course_project as cp

WS = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


class CpuHog:
    """One process spinning on a core from __enter__ to __exit__; share(): the share of
    one core it used over that time (from /proc)."""

    def __enter__(self):
        self.proc = subprocess.Popen([sys.executable, "-c", "while True: pass"])
        self.wall0 = time.monotonic()
        return self

    def share(self):
        return rs.cpu_seconds(self.proc.pid) / max(time.monotonic() - self.wall0, 1e-6)

    def __exit__(self, *exc):
        self.proc.kill()
        self.proc.wait()


def process_tree(root):
    """Pids of root and all its descendants."""
    return [p.pid for p in rs.process_tree(root)]


def tree_threads(root):
    """(pid, tid) of every thread of root's process tree."""
    out = []
    for pid in process_tree(root):
        try:
            out.extend((pid, int(tid)) for tid in os.listdir(f"/proc/{pid}/task"))
        except OSError:
            pass
    return out


class OneCore:
    """Confines the process tree under `root` (the rostest process: simulator, roslaunch,
    nodes, this test node) to one CPU. Affinity is per thread and inherited by new
    threads and processes, so every thread there now is pinned; unconfined() lists the
    threads of the tree that are not (processes started since inherit it)."""

    def __init__(self, root):
        self.root = root
        self.cpu = max(os.sched_getaffinity(0))

    def __enter__(self):
        for _ in range(3):      # a thread started while we pinned is caught next round
            for _pid, tid in self.unconfined():
                try:
                    os.sched_setaffinity(tid, {self.cpu})
                except (ProcessLookupError, PermissionError):
                    pass
        return self

    def unconfined(self):
        out = []
        for pid, tid in tree_threads(self.root):
            try:
                if os.sched_getaffinity(tid) != {self.cpu}:
                    out.append((pid, tid))
            except ProcessLookupError:
                pass
        return out

    def __exit__(self, *exc):
        pass


class CourseProjectEndToEnd(unittest.TestCase):
    def test_course_project(self):
        rospy.init_node("course_project_test")
        one_core = rospy.get_param("~one_core", False)
        with (OneCore(os.getppid()) if one_core else contextlib.nullcontext()) as core, \
                (CpuHog() if rospy.get_param("~cpu_hog", False) else contextlib.nullcontext()) as hog:
            if core is not None:
                print(f"ONE_CORE the run is confined to CPU {core.cpu}: "
                      f"{len(tree_threads(core.root))} threads now", flush=True)
            self.run_course_project()
            if core is not None:
                left = core.unconfined()
                self.assertEqual(left, [], "threads of the run not confined to one CPU (pid, tid)")
            if hog is not None:
                self.assertIsNone(hog.proc.poll(), "the CPU hog ended before the run did")
                share = hog.share()
                print(f"CPU_HOG used {share:.2f} of a core", flush=True)
                self.assertGreaterEqual(share, rospy.get_param("~cpu_hog_min_share"),
                                        "the CPU hog did not keep a core busy: the run was not under load")

    def run_course_project(self):
        xy_tol, yaw_tol = rospy.get_param("~xy_tolerance"), rospy.get_param("~yaw_tolerance")
        work = os.path.join(rospkg.get_ros_home(), "course_project")
        wall0 = time.monotonic()

        def progress(text):
            print(f"[sim {rospy.Time.now().to_sec():7.1f} s | wall {time.monotonic() - wall0:6.1f} s] {text}",
                  flush=True)

        from my_summit_mapping.slam_config import SlamConfig
        from summit_xl_sim.world import World
        world = World.from_yaml(rospy.get_param("/summit_xl_sim/world"))
        with open(os.path.join(WS, "src", "my_summit_mapping", "config", "gmapping_params.yaml")) as f:
            max_urange = SlamConfig.from_dict(yaml.safe_load(f)).maxUrange
        with cp.CourseProject(work, world_spots(cp.WORLD_DESCRIPTION), progress) as project:
            project.wait(lambda: project.pose() is not None, "waiting for ground truth", 60)
            # 1. map, save, stop gmapping
            recorder = project.map_building(TourRecorder)
            quality = recorder.evaluate(world, max_urange, LaserParams())
            progress(f"map: ATE {quality['ate_m']:.3f} m, precision {quality['precision']:.3f}, "
                     f"recall {quality['recall']:.3f}")
            base = os.path.join(work, "my_map")
            initial = project.save_map(base)
            # 2. localize on the saved map, record the spots
            spots_file = os.path.join(work, "spots.txt")
            project.start_navigation(base + ".yaml", initial, spots_file)
            for label in cp.RECORD_ORDER:
                state, text = project.drive_to(label)
                self.assertEqual(state, 3, f"driving to '{label}' to record it: {text}")
                resp = project.call("/save_spot", label)
                self.assertTrue(resp.navigation_successfull, f"/save_spot '{label}': {resp.message}")
                err = project.error_to(label)
                progress(f"/save_spot '{label}': {resp.message} (robot {err[0]:.3f} m, "
                         f"{math.degrees(err[1]):.1f} deg from the spot)")
            resp = project.call("/save_spot", "end")
            self.assertTrue(resp.navigation_successfull, f"/save_spot 'end': {resp.message}")
            with open(spots_file) as f:
                saved = yaml.safe_load(f)
            self.assertEqual(set(cp.RECORD_ORDER), set(saved["spots"]), saved)
            # back to the hall, so that the calls cross from the hall into the fetch room
            state, text = project.drive_home()
            self.assertEqual(state, 3, f"driving back to the hall: {text}")
            # 4. /get_coordinates
            rows = []
            for label in cp.SPOT_ORDER:
                t0 = rospy.Time.now().to_sec()
                resp = project.call("/get_coordinates", label)
                rospy.sleep(0.5)
                err = project.error_to(label)
                rows.append((label, resp.navigation_successfull, resp.message, err))
                print(f"GET_COORDINATES label={label} ok={resp.navigation_successfull} message={resp.message!r} "
                      f"sim_time_s={rospy.Time.now().to_sec() - t0:.1f} final_xy_error_m={err[0]:.3f} "
                      f"final_yaw_error_rad={err[1]:.3f} collisions={project.collisions}", flush=True)
            progress(f"done: {project.collisions} collisions")
            print(f"SCANS_SKIPPED {project.skipped_summary()}", flush=True)
            self.assertGreaterEqual(quality["precision"], rospy.get_param("~min_precision"))
            self.assertGreaterEqual(quality["recall"], rospy.get_param("~min_recall"))
            for label, ok, message, (exy, eyaw) in rows:
                self.assertTrue(ok, f"/get_coordinates '{label}': {message}")
                self.assertEqual(message, "OK", label)
                self.assertLessEqual(exy, xy_tol, f"{label}: {exy:.3f} m from the spot")
                self.assertLessEqual(eyaw, yaw_tol, f"{label}: {eyaw:.3f} rad off the spot's heading")
            self.assertEqual(project.collisions, 0, "the robot collided")


if __name__ == "__main__":
    rostest.rosrun("my_summit_navigation", "course_project", CourseProjectEndToEnd, sys.argv)
