#!/usr/bin/python3
"""`make demo`: the whole course project, headless, with progress lines, a table and pictures.

The simulator runs throughout; my_summit_navigation.course_project (shared with the end-to-end
rostest, tests/course_project.test) then does what the student does:

1. slam_gmapping maps the building while the tour driver takes the Summit XL through
   every room (the student at the keyboard); map_saver saves the map; gmapping stops;
2. main.launch (map_server, amcl, move_base, /get_coordinates) and the spot recorder
   start on the saved map, amcl from SLAM's last pose; the robot is driven to each spot
   and /save_spot records it, then 'end' writes spots.txt;
3. the robot goes back to the hall, and /get_coordinates is called for table, room and
   turtle; each answer and the pose reached (ground truth) go into the table.

Pictures in output/: demo_tour.png (world, driven trajectory, one scan), demo_slam_map.png
(the SLAM map judged against the true walls), demo_particles.png (amcl's particle cloud
at the start and after it converged), demo_nav_<label>.png (plan and driven path to each
spot over the global costmap). The saved map and spots file: output/demo_run/.

    make demo            headless
    make demo GUI=1      the same with rviz open (needs a display)
    make demo SPEED=4    the simulator at 4x real time (the last line names the scans any
                         node had to skip because it fell behind)
"""
import argparse
import math
import os
import shutil
import sys
import threading
import time

import cv2
import numpy as np

from summit_nav_common.geometry import quaternion_to_yaw, relative
from summit_nav_common.testing.roslaunch_session import RoslaunchSession, wait_for_sim_time_param

from my_summit_navigation import course_project as cp

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(WS, "output")
# A map below these (share of mapped cells on true walls / of seen walls mapped) is reported
# as poor in the table (the mapping issue's figures are 0.95 / 0.90).
MAP_PRECISION_OK = 0.90
MAP_RECALL_OK = 0.85
SPEED = 1.0            # simulated seconds per wall second by default (make demo SPEED=4 for faster)
XY_TOL, YAW_TOL = 0.3, 0.3   # [m], [rad] the course's figure, by ground truth


class Progress:
    """Prints one line per event with simulated and wall time (since the demo started)."""

    def __init__(self):
        self.wall0 = time.monotonic()

    def __call__(self, text):
        import rospy
        sim_t = rospy.Time.now().to_sec() if rospy.core.is_initialized() else 0.0
        print(f"[sim {sim_t:7.1f} s | wall {time.monotonic() - self.wall0:6.1f} s] {text}", flush=True)


def draw_world_picture(world, trajectory, scan_pose, scan_xy, path, scale=3):
    """The world map with the trajectory (blue), a scan (red) and the robot (green)."""
    base = np.where(world.grid.data == 100, 0, np.where(world.grid.data == 0, 255, 205)).astype(np.uint8)
    img = cv2.cvtColor(base[::-1], cv2.COLOR_GRAY2BGR)
    img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    h = img.shape[0]

    def px(x, y):
        gx, gy = world.to_grid(x, y)
        return int(round(gx * scale)), int(round(h - gy * scale))

    if len(trajectory) > 1:
        pts = np.array([px(x, y) for x, y in trajectory], np.int32)
        cv2.polylines(img, [pts], False, (200, 90, 20), 2, cv2.LINE_AA)
    for x, y in scan_xy:
        cv2.circle(img, px(x, y), 2, (0, 0, 230), -1, cv2.LINE_AA)
    if scan_pose is not None:
        x, y, yaw = scan_pose
        c, s = math.cos(yaw), math.sin(yaw)
        corners = [(x + c * a - s * b, y + s * a + c * b)
                   for a, b in ((0.36, 0.31), (-0.36, 0.31), (-0.36, -0.31), (0.36, -0.31))]
        cv2.polylines(img, [np.array([px(*p) for p in corners], np.int32)], True, (0, 160, 0), 2, cv2.LINE_AA)
        cv2.line(img, px(x, y), px(x + 0.5 * c, y + 0.5 * s), (0, 160, 0), 2, cv2.LINE_AA)
    cv2.putText(img, "Summit XL tour: trajectory (blue), one laser scan (red), robot (green)",
                (10, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (40, 40, 40), 1, cv2.LINE_AA)
    tmp = path + ".tmp.png"
    cv2.imwrite(tmp, img)
    os.replace(tmp, path)



def known_bbox(data, margin):
    """(row0, row1, col0, col1) of the grid's known cells (value >= 0) plus margin cells:
    a SLAM map spans gmapping's whole xmin..ymax window, mostly unknown."""
    rows, cols = np.nonzero(data >= 0)
    if len(rows) == 0:
        return 0, data.shape[0], 0, data.shape[1]
    return (max(0, rows.min() - margin), min(data.shape[0], rows.max() + 1 + margin),
            max(0, cols.min() - margin), min(data.shape[1], cols.max() + 1 + margin))


def draw_costmap_picture(costmap, plan_xy, driven_xy, spot, path, title, scale=3):
    """The global costmap (CostmapClient.snapshot(): header, info, grid; grey levels, lethal
    black, inflation shaded), the plan (blue) and the driven path (green) to a spot (red
    arrow), in the map frame."""
    _, info, grid = costmap
    data = grid.astype(np.int16)
    res = info.resolution
    r0, r1, c0, c1 = known_bbox(data, int(round(1.0 / res)))
    data = data[r0:r1, c0:c1]
    ox, oy = info.origin.position.x + c0 * res, info.origin.position.y + r0 * res
    base = np.where(data < 0, 205, 255 - np.clip(data, 0, 100) * 2.2).astype(np.uint8)
    img = cv2.resize(cv2.cvtColor(base[::-1], cv2.COLOR_GRAY2BGR), None, fx=scale, fy=scale,
                     interpolation=cv2.INTER_NEAREST)
    h = img.shape[0]

    def px(x, y):
        return int(round((x - ox) / res * scale)), int(round(h - (y - oy) / res * scale))

    for pts, colour in ((plan_xy, (220, 120, 0)), (driven_xy, (0, 170, 0))):
        if len(pts) > 1:
            cv2.polylines(img, [np.array([px(x, y) for x, y in pts], np.int32)], False, colour, 2, cv2.LINE_AA)
    x, y, yaw = spot
    cv2.arrowedLine(img, px(x, y), px(x + 0.6 * math.cos(yaw), y + 0.6 * math.sin(yaw)), (0, 0, 230), 2,
                    cv2.LINE_AA, tipLength=0.35)
    cv2.putText(img, title, (10, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (30, 30, 30), 1, cv2.LINE_AA)
    tmp = path + ".tmp.png"
    cv2.imwrite(tmp, img)
    os.replace(tmp, path)


def draw_particles_picture(map_yaml, clouds, path, scale=3):
    """The saved map twice side by side, each with one amcl particle cloud (red arrows)
    and the true robot pose (green): clouds is [(title, [(x, y, yaw)], truth_pose_map)]."""
    from summit_nav_common.map_io import load_map
    m = load_map(map_yaml)
    r0, r1, c0, c1 = known_bbox(m.data, int(round(1.0 / m.resolution)))
    data = m.data[r0:r1, c0:c1]
    ox, oy = m.origin[0] + c0 * m.resolution, m.origin[1] + r0 * m.resolution
    base = np.where(data == 100, 0, np.where(data == 0, 255, 205)).astype(np.uint8)
    panels = []
    for title, poses, truth in clouds:
        img = cv2.resize(cv2.cvtColor(base[::-1], cv2.COLOR_GRAY2BGR), None, fx=scale, fy=scale,
                         interpolation=cv2.INTER_NEAREST)
        h = img.shape[0]

        def px(x, y):
            return (int(round((x - ox) / m.resolution * scale)),
                    int(round(h - (y - oy) / m.resolution * scale)))

        for x, y, yaw in poses:
            cv2.arrowedLine(img, px(x, y), px(x + 0.25 * math.cos(yaw), y + 0.25 * math.sin(yaw)), (0, 0, 220), 1,
                            cv2.LINE_AA, tipLength=0.4)
        x, y, yaw = truth
        cv2.circle(img, px(x, y), 6, (0, 160, 0), 2, cv2.LINE_AA)
        cv2.line(img, px(x, y), px(x + 0.5 * math.cos(yaw), y + 0.5 * math.sin(yaw)), (0, 160, 0), 2, cv2.LINE_AA)
        cv2.putText(img, title, (10, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (30, 30, 30), 1, cv2.LINE_AA)
        panels.append(img)
    img = np.hstack([np.pad(p, ((0, 0), (0, 8), (0, 0)), constant_values=255) for p in panels])
    tmp = path + ".tmp.png"
    cv2.imwrite(tmp, img)
    os.replace(tmp, path)


class Watch:
    """What the pictures need, from topics: one laser scan (fetch room), amcl's particle
    clouds, the global plan and costmap."""

    def __init__(self, project):
        import rospy
        from geometry_msgs.msg import PoseArray
        from nav_msgs.msg import Path
        from rospy.numpy_msg import numpy_msg
        from sensor_msgs.msg import LaserScan
        self.project = project
        self.lock = threading.Lock()
        self.scan, self.scan_pose = None, None
        self.cloud = None
        self.plan = None
        # the whole grid once, then the windows redrawn since on costmap_updates
        from summit_nav_common.ros.costmap_client import CostmapClient
        self.costmap = CostmapClient("/move_base/global_costmap/costmap")
        self.subs = [
            rospy.Subscriber("/hokuyo_base/scan", numpy_msg(LaserScan), self._on_scan, queue_size=1),
            rospy.Subscriber("/particlecloud", PoseArray, self._on_cloud, queue_size=1),
            rospy.Subscriber("/move_base/NavfnROS/plan", Path, self._on_plan, queue_size=1)]

    def _on_scan(self, msg):
        pose = self.project.pose()
        # Keep the scan taken nearest the fetch room's centre: it shows the table legs.
        if pose is not None and (self.scan_pose is None or math.hypot(pose[0] - 16.0, pose[1] - 3.5)
                                 < math.hypot(self.scan_pose[0] - 16.0, self.scan_pose[1] - 3.5)):
            with self.lock:
                self.scan, self.scan_pose = np.array(msg.ranges), pose

    def _on_cloud(self, msg):
        self.cloud = [(p.position.x, p.position.y, quaternion_to_yaw(p.orientation)) for p in msg.poses]

    def _on_plan(self, msg):
        self.plan = [(p.pose.position.x, p.pose.position.y) for p in msg.poses]

    def scan_points(self):
        """The kept scan's end points in the world frame."""
        with self.lock:
            pose, ranges = self.scan_pose, self.scan
        if ranges is None:
            return pose, []
        lx, ly = pose[0] + 0.25 * math.cos(pose[2]), pose[1] + 0.25 * math.sin(pose[2])
        ang = np.linspace(-2.356194490192345, 2.356194490192345, len(ranges)) + pose[2]
        ok = np.isfinite(ranges)
        return pose, np.column_stack([lx + ranges[ok] * np.cos(ang[ok]), ly + ranges[ok] * np.sin(ang[ok])])


def run_course(progress, gui, seed, work, speed=SPEED):
    """The course project on a fresh simulator; returns the table's rows."""
    import rospy
    import yaml
    from my_summit_mapping.slam_config import SlamConfig
    from summit_xl_sim.sim import LaserParams
    from summit_xl_sim.world import World
    from summit_xl_sim.worldgen import world_spots
    from my_summit_mapping.tour_recorder import TourRecorder, write_png

    world = World.from_yaml(os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml"))
    with open(os.path.join(WS, "src", "my_summit_mapping", "config", "gmapping_params.yaml")) as f:
        slam_cfg = SlamConfig.from_dict(yaml.safe_load(f))
    rviz = os.path.join(WS, "src", "my_summit_path_planning", "rviz", "navigation.rviz")
    args = ["summit_xl_sim", "sim.launch", f"speed:={speed}", f"seed:={seed}", f"gui:={'true' if gui else 'false'}",
            f"rviz_config:={rviz}"]
    rows = []

    def row(step, ok, sim_s, wall_s, detail, result=None):
        rows.append({"step": step, "result": result or ("ok" if ok else "FAILED"), "sim_s": sim_s,
                     "wall_s": wall_s, "detail": detail})

    with RoslaunchSession(args, log=os.path.join(work, "sim.log")) as session:
        wait_for_sim_time_param(session)
        rospy.init_node("demo", anonymous=True, disable_signals=True)
        with cp.CourseProject(work, world_spots(cp.WORLD_DESCRIPTION), progress, wall_limit=900.0) as project:
            watch = Watch(project)
            project.wait(lambda: project.pose() is not None, "waiting for the simulator", 60)
            progress(f"simulator up at {speed:g}x real time (seed {seed}), robot at the spawn pose "
                     f"({project.spawn[0]:.1f}, {project.spawn[1]:.1f})")
            # 1. mapping
            t0, w0 = rospy.Time.now().to_sec(), time.monotonic()
            recorder = project.map_building(TourRecorder)
            result = recorder.evaluate(world, slam_cfg.maxUrange, LaserParams())
            with recorder.lock:
                traj = [(x, y) for _, x, y, _ in recorder.truth]
            length = float(np.sum(np.hypot(*np.diff(np.array(traj), axis=0).T))) if len(traj) > 1 else 0.0
            good = result["precision"] >= MAP_PRECISION_OK and result["recall"] >= MAP_RECALL_OK
            progress(f"map judged against the true walls: ATE {result['ate_m']:.3f} m, precision "
                     f"{result['precision']:.3f}, recall {result['recall']:.3f}")
            row("1. map the building (slam_gmapping + tour)", good and project.collisions == 0,
                rospy.Time.now().to_sec() - t0, time.monotonic() - w0,
                f"{length:.1f} m driven, {project.collisions} collisions; SLAM ATE {result['ate_m']:.3f} m, "
                f"precision {result['precision']:.3f} / recall {result['recall']:.3f}",
                None if good or project.collisions else "POOR MAP")
            pose, scan_xy = watch.scan_points()
            draw_world_picture(world, traj, pose, scan_xy, os.path.join(OUT, "demo_tour.png"))
            write_png(result, os.path.join(OUT, "demo_slam_map.png"), world)
            progress("pictures: output/demo_tour.png, output/demo_slam_map.png")
            t0, w0 = rospy.Time.now().to_sec(), time.monotonic()
            base = os.path.join(work, "my_map")
            initial = project.save_map(base)
            row("1. save the map (map_saver), stop gmapping", True, rospy.Time.now().to_sec() - t0,
                time.monotonic() - w0, f"{os.path.relpath(base, WS)}.pgm/.yaml; SLAM's last pose "
                f"({initial[0]:.2f}, {initial[1]:.2f}, {math.degrees(initial[2]):.0f} deg) -> amcl")

            # 2. localization, the spot recorder
            t0, w0 = rospy.Time.now().to_sec(), time.monotonic()
            spots_file = os.path.join(work, "spots.txt")
            project.start_navigation(base + ".yaml", initial, spots_file)
            project.wait(lambda: watch.cloud is not None, "waiting for amcl's particle cloud", 30)
            truth_map = relative(project.spawn, project.pose())
            clouds = [("amcl at start: initial cloud (red), truth (green)", watch.cloud, truth_map)]
            for label in cp.RECORD_ORDER:
                state, text = project.drive_to(label)
                if state != 3:
                    raise cp.StepFailed(f"driving to '{label}' to record it: {text}")
                if len(clouds) == 1:
                    clouds.append((f"after driving to '{label}': converged", watch.cloud,
                                   relative(project.spawn, project.pose())))
                resp = project.call("/save_spot", label)
                exy, eyaw = project.error_to(label)
                progress(f"/save_spot '{label}': {resp.message}; robot {exy:.3f} m / {math.degrees(eyaw):.1f} deg "
                         "from the spot (ground truth)")
                if not resp.navigation_successfull:
                    raise cp.StepFailed(f"/save_spot '{label}': {resp.message}")
            resp = project.call("/save_spot", "end")
            progress(f"/save_spot 'end': {resp.message}")
            draw_particles_picture(base + ".yaml", clouds, os.path.join(OUT, "demo_particles.png"))
            row("2. localize (amcl) and record the spots (/save_spot)", resp.navigation_successfull,
                rospy.Time.now().to_sec() - t0, time.monotonic() - w0,
                f"{', '.join(cp.RECORD_ORDER)} + end -> {os.path.relpath(spots_file, WS)}; "
                f"{project.collisions} collisions so far")
            state, text = project.drive_home()
            progress(f"back at the start in the hall: {text}")

            # 3. /get_coordinates
            for label in cp.SPOT_ORDER:
                t0, w0 = rospy.Time.now().to_sec(), time.monotonic()
                watch.plan = None
                driven, first_plan = [], None
                progress(f"rosservice call /get_coordinates \"label: '{label}'\"")
                box = {}
                th = threading.Thread(target=lambda: box.update(resp=project.call("/get_coordinates", label)),
                                      daemon=True)
                th.start()
                while th.is_alive():
                    if first_plan is None and watch.plan:
                        first_plan = watch.plan
                    p = project.pose()
                    driven.append(relative(project.spawn, p)[:2])
                    th.join(0.1)
                if "resp" not in box:
                    raise cp.StepFailed(f"/get_coordinates '{label}' failed (see the launch logs in {work})")
                resp = box["resp"]
                rospy.sleep(0.5)
                exy, eyaw = project.error_to(label)
                ok = resp.navigation_successfull and exy <= XY_TOL and eyaw <= YAW_TOL
                progress(f"/get_coordinates '{label}': {resp.navigation_successfull}, \"{resp.message}\"; ground truth "
                         f"{exy:.3f} m / {math.degrees(eyaw):.1f} deg from the spot")
                costmap = watch.costmap.snapshot()
                if costmap is not None:
                    draw_costmap_picture(costmap, first_plan or [], driven, project.spot_in_map(label),
                                         os.path.join(OUT, f"demo_nav_{label}.png"),
                                         f"/get_coordinates '{label}': plan (blue), driven (green), global costmap")
                row(f"3. /get_coordinates '{label}'", ok, rospy.Time.now().to_sec() - t0, time.monotonic() - w0,
                    f"\"{resp.message}\"; pose error {exy:.3f} m / {math.degrees(eyaw):.1f} deg; "
                    f"{project.collisions} collisions so far")
            progress(f"done: {project.collisions} collisions over the whole run; scans skipped by "
                     f"nodes that fell behind: {project.skipped_summary()}")
            if project.collisions:
                row("whole run", False, 0.0, 0.0, f"{project.collisions} collisions")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gui", action="store_true", help="open rviz (needs a display)")
    ap.add_argument("--seed", type=int, default=0, help="the simulator's noise seed")
    ap.add_argument("--speed", type=float, default=SPEED,
                    help="simulated seconds per wall second (e.g. 4; each node reports the scans it had to skip)")
    args = ap.parse_args()
    if not 0 < args.speed <= 10:
        ap.error(f"--speed must be in (0, 10], got {args.speed:g}")
    os.makedirs(OUT, exist_ok=True)
    work = os.path.join(OUT, "demo_run")
    shutil.rmtree(work, ignore_errors=True)  # no map or spots.txt of an earlier run may be picked up
    os.makedirs(work)
    progress = Progress()
    try:
        rows = run_course(progress, args.gui, args.seed, work, args.speed)
        failure = None
    except (cp.StepFailed, RuntimeError) as e:
        rows, failure = [], str(e)
    print("\n| step | result | sim time [s] | wall time [s] | detail |\n| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['step']} | {r['result']} | {r['sim_s']:.1f} | {r['wall_s']:.1f} | {r['detail']} |")
    if failure:
        print(f"| (stopped) | FAILED | | | {failure} |")
    print(f"\ntotal wall time {time.monotonic() - progress.wall0:.0f} s; pictures in output/, "
          f"launch logs and the saved map in {os.path.relpath(work, WS)}/")
    return 0 if rows and not failure and all(r["result"] == "ok" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
