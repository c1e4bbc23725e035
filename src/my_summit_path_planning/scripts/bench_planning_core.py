#!/usr/bin/env python3
"""Benchmark of the path-planning core (no ROS): NavFn, GlobalPlanner, one DWA cycle, closed loop.

1. NavFn, and global_planner/GlobalPlanner (default parameters but the course's NavfnROS
   allow_unknown and default_tolerance, as NavFn has them: both plan over the cells the
   geodesic counts) with Dijkstra and with A*, on willow-full-0.05 between the same
   far-apart free cells: median plan time over seeded pairs, and the path length against
   the exact 8-connected grid geodesic (for GlobalPlanner also with neutral_cost 255,
   every passable cell weighing the same: the path geometry alone).
2. One DWA control cycle (the course's sample counts) on a local costmap: median time.
3. Closed loop: move_base's executive (move_base_core.MoveBaseCore: PLANNING /
   CONTROLLING / CLEARING, patience timers, oscillation watch, the recovery behaviours
   built from the config) drives summit_xl_sim.sim.Simulation on simulated time, with
   ground-truth pose: the global costmap (static + obstacle + inflation) and the rolling
   local costmap updated from the laser at their update_frequency, the global planner
   planning when the core asks (as the node's planner thread: at planner_frequency while
   driving, once per control cycle while the goal waits for a plan), the local planner
   every control period; between seeded random free pose
   pairs (the same pairs for every planner). Reports the share reached within tolerance
   (a goal the core aborts fails with its text), collisions, and the median of
   time-to-goal / (L / max_vel_x) with L the exact 8-connected grid geodesic
   (navfn.grid_geodesic_length, the same yardstick for every planner; the benchmark's
   target) and with L that run's first plan's length. The plugins are built by their type
   strings through plugins.MoveBasePlugins, as move_base builds them:
     --global-planner navfn     navfn/NavfnROS (config/)
                      astar     global_planner/GlobalPlanner, use_dijkstra false
                      dijkstra  global_planner/GlobalPlanner, use_dijkstra true
     --local-planner  dwa            dwa_local_planner/DWAPlannerROS (config/)
                      trajectory     base_local_planner/TrajectoryPlannerROS, dwa false
                      trajectory-dwa base_local_planner/TrajectoryPlannerROS, dwa true
   GlobalPlanner gets the course's NavfnROS allow_unknown and default_tolerance, its other
   parameters default; the local planners run with the config's namespaces
   (TrajectoryPlannerROS: base_local_planner_params.yaml, the navigation_stage lesson's
   values with the Summit's turning limits and the planner's sim_time), the dwa flag from
   the option. --matrix runs every combination over the same pairs and prints a table;
   each combination is one JSON key (combination_key). --jobs N runs N pairs at a time in
   forked processes (the closed loop is simulated and seeded: the same figures); --parts
   DIR writes each combination as it is done, --resume takes those of the same commit.

Parameters come from the package's config/*.yaml. Usage:
  bench_planning_core.py [--runs 50] [--willow-runs 20] [--repeats 3] [--json PATH]
                         [--max-vel-x 1.5] [--global-planner navfn|astar|dijkstra]
                         [--local-planner dwa|trajectory|trajectory-dwa] [--matrix] [--jobs 2]
                         [--parts DIR [--resume]]
  replay one run: --skip-navfn --runs 10 --only 7 -v --trace 0.5
"""
import argparse
import dataclasses
import json
import math
import os
import resource
import sys
import threading
import time

import numpy as np

from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.dwa import DWAPlanner
from my_summit_path_planning.global_planner import GlobalPlanner, GlobalPlannerConfig
from my_summit_path_planning.layers import (ObstacleLayer, StaticLayer, scan_to_observation,
                                            source_observation)
from my_summit_path_planning.move_base_core import (INFO, INVALID_GOAL, GoalError, MoveBaseCore,
                                                    accept_goal)
from my_summit_path_planning.nav_core import namespace_of
from my_summit_path_planning.navfn import NavFn, grid_geodesic_length
from my_summit_path_planning.params import build_costmap, load_move_base_params
from my_summit_path_planning.plugins import MoveBasePlugins
from summit_nav_common.geometry import angle_diff
from summit_nav_common.testing.provenance import git_commit  # the commit stamp of the benchmark page

HERE = os.path.dirname(os.path.abspath(__file__))

CONFIG = os.path.join(HERE, "..", "config")
WS_SRC = os.path.abspath(os.path.join(HERE, "..", ".."))
WORKSPACE = os.path.dirname(WS_SRC)
BUILTIN = os.path.join(WS_SRC, "summit_xl_sim", "worlds", "course_building.yaml")
WILLOW = os.path.join(WORKSPACE, "data", "maps", "willow-full-0.05.yaml")  # the workspace's data/
SIM_DT = 0.005            # [s] simulator step
MIN_PAIR_DIST = 2.0       # [m] closed-loop start-goal distance at least
FAR_PAIR_DIST = 25.0      # [m] NavFn benchmark pairs at least this far apart
TIME_LIMIT_FACTOR = 6.0   # a run fails after this x optimal time ...
TIME_LIMIT_MIN = 40.0     # ... but never before this [s] of simulated time
TIME_EPS = 1e-9           # [s] simulated times this close are the same instant
IDENTITY = (0.0, 0.0, 0.0)  # global -> local frame: both the world's (perfect localization)
# The closed loop's planners: option -> (move_base type string, its namespace's parameters
# over the config's). GlobalPlanner also gets COURSE_GLOBAL_PARAMS from the config's NavfnROS.
GLOBAL_KINDS = {
    "navfn": ("navfn/NavfnROS", {}),
    "astar": ("global_planner/GlobalPlanner", {"use_dijkstra": False}),
    "dijkstra": ("global_planner/GlobalPlanner", {"use_dijkstra": True}),
}
COURSE_GLOBAL_PARAMS = ("allow_unknown", "default_tolerance")  # the course's choices for any global planner
LOCAL_KINDS = {   # each with the config's namespace (TrajectoryPlannerROS: base_local_planner_params.yaml)
    "dwa": ("dwa_local_planner/DWAPlannerROS", {}),
    "trajectory": ("base_local_planner/TrajectoryPlannerROS", {"dwa": False}),
    "trajectory-dwa": ("base_local_planner/TrajectoryPlannerROS", {"dwa": True}),
}
GLOBAL_PLANNERS, LOCAL_PLANNERS = tuple(GLOBAL_KINDS), tuple(LOCAL_KINDS)
WORLDS = (("builtin", BUILTIN), ("willow", WILLOW))   # JSON key part, map


def peak_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def global_costmap(params, grid):
    g = build_costmap(params.global_costmap, "global_costmap")
    g.layer("static_layer").set_map(grid.data, grid.resolution, grid.origin)
    g.update_map(0.0, 0.0, 0.0)
    return g


def willow_costmap(params):
    """The global costmap (course parameters) of willow-full-0.05."""
    from summit_nav_common.map_io import load_map
    return global_costmap(params, load_map(WILLOW)).master


def far_pairs(cm, n_pairs, seed=0):
    """n_pairs seeded pairs of free cells at least FAR_PAIR_DIST apart and connected:
    [((row, col) start, (row, col) goal, exact 8-connected grid geodesic [m]), ...]."""
    rng = np.random.default_rng(seed)
    passable = cm.data < cv.INSCRIBED_INFLATED_OBSTACLE
    free = np.argwhere(cm.data == cv.FREE_SPACE)
    pairs = []
    while len(pairs) < n_pairs:
        a, b = free[rng.integers(len(free))], free[rng.integers(len(free))]
        if math.hypot(*(a - b)) * cm.resolution < FAR_PAIR_DIST:
            continue
        geo = grid_geodesic_length(passable, (a[1], a[0]), (b[1], b[0])) * cm.resolution
        if math.isfinite(geo):
            pairs.append((a, b, geo))
    return pairs


def bench_plans(planner, cm, pairs, name):
    """Time planner.make_plan over pairs (one warm-up plan first): median wall / CPU time
    and path length against the grid geodesic."""
    free = np.argwhere(cm.data == cv.FREE_SPACE)
    planner.make_plan(cm, cm.map_to_world(free[0][1], free[0][0]),
                      cm.map_to_world(free[0][1], free[0][0]))  # caches, compiled kernels
    times, cpu, ratios, lengths, geos = [], [], [], [], []
    for a, b, geo in pairs:
        t0, c0 = time.perf_counter(), time.process_time()
        r = planner.make_plan(cm, cm.map_to_world(a[1], a[0]), cm.map_to_world(b[1], b[0]))
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        if not r.ok:
            raise RuntimeError(f"{name} failed on a connected pair: {r.reason}")
        lengths.append(r.length)
        geos.append(geo)
        ratios.append(r.length / geo)
    return {"pairs": len(pairs), "map_cells": int(cm.data.size),
            "median_ms": 1000 * float(np.median(times)), "max_ms": 1000 * float(np.max(times)),
            "cpu_median_ms": 1000 * float(np.median(cpu)),
            "median_path_m": float(np.median(lengths)), "median_geodesic_m": float(np.median(geos)),
            "length_ratio_median": float(np.median(ratios)),
            "length_ratio_max": float(np.max(ratios)), "length_ratio_min": float(np.min(ratios))}


def bench_navfn(params, n_pairs, seed=0, cm=None, pairs=None):
    cm = cm if cm is not None else willow_costmap(params)
    pairs = pairs if pairs is not None else far_pairs(cm, n_pairs, seed)
    return bench_plans(NavFn(params.navfn), cm, pairs, "NavFn")


def bench_global_planner(use_dijkstra, cm, pairs, course=None):
    """global_planner/GlobalPlanner with its default parameters (A* when not use_dijkstra)
    but course's (a dict: the course's COURSE_GLOBAL_PARAMS), plus the same plans with
    neutral_cost 255 (every passable cell then costs lethal_cost - 1: the path geometry
    without the costs)."""
    course = dict(course or {})
    planner = GlobalPlanner(GlobalPlannerConfig(use_dijkstra=use_dijkstra, **course))
    out = bench_plans(planner, cm, pairs, "GlobalPlanner")
    cells = []
    for a, b, _ in pairs:
        planner.make_plan(cm, cm.map_to_world(a[1], a[0]), cm.map_to_world(b[1], b[0]))
        cells.append(planner.cells_expanded)
    out["cells_expanded_median"] = float(np.median(cells))
    geometric = bench_plans(GlobalPlanner(GlobalPlannerConfig(use_dijkstra=use_dijkstra, neutral_cost=255, **course)),
                            cm, pairs, "GlobalPlanner")
    out["geometric_length_ratio_median"] = geometric["length_ratio_median"]
    out["geometric_length_ratio_max"] = geometric["length_ratio_max"]
    return out


def bench_dwa_cycle(params, n=200, seed=0):
    from my_summit_path_planning.costmap import LayeredCostmap  # noqa: F401
    rng = np.random.default_rng(seed)
    loc = build_costmap(params.local_costmap, "local_costmap")
    layer = loc.layer("obstacle_layer")
    ang = np.linspace(-2.356, 2.356, 1081)
    ranges = 2.0 + 1.5 * np.abs(np.sin(3 * ang)) + rng.normal(0, 0.01, ang.size)
    layer.add_observation(scan_to_observation(ranges, -2.356, ang[1] - ang[0], 0.1, 30.0,
                                              (0.25, 0.0, 0.0), True, 4.0, 4.5))
    loc.update_map(0.0, 0.0, 0.0)
    dwa = DWAPlanner(params.dwa, loc.footprint)
    plan = np.column_stack([np.linspace(0, 3, 61), 0.3 * np.sin(np.linspace(0, 3, 61))])
    dwa.set_plan(plan, 0.0)
    times, cpu = [], []
    for i in range(n):
        vel = (rng.uniform(0.0, 1.2), 0.0, rng.uniform(-1.0, 1.0))
        t0, c0 = time.perf_counter(), time.process_time()
        r = dwa.compute_velocity((0.0, 0.0, 0.0), vel, loc.master)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        dwa.oscillation.reset()
    return {"cycles": n, "samples": r.n_samples, "median_ms": 1000 * float(np.median(times)),
            "cpu_median_ms": 1000 * float(np.median(cpu)),
            "p90_ms": 1000 * float(np.percentile(times, 90))}


def combination_params(params, global_kind="navfn", local_kind="dwa", max_vel_x=None):
    """params (a MoveBaseParams, not modified) as move_base would be configured for this
    (global, local) combination: base_global_planner / base_local_planner set to the
    kinds' type strings and their namespaces merged over the config's (GLOBAL_KINDS,
    LOCAL_KINDS; every global planner with the config's NavfnROS COURSE_GLOBAL_PARAMS);
    max_vel_x [m/s]: the local planner's top speed (and DWA's max_vel_trans)."""
    gtype, gns = GLOBAL_KINDS[global_kind]
    ltype, lns = LOCAL_KINDS[local_kind]
    spaces = dict(params.namespaces)
    course = params.namespace("NavfnROS")
    gns = {**{k: course[k] for k in COURSE_GLOBAL_PARAMS if k in course}, **gns}
    for type_name, extra in ((gtype, gns), (ltype, lns)):
        name = namespace_of(type_name)
        spaces[name] = {**(spaces.get(name) or {}), **extra}
    if max_vel_x:
        local = spaces[namespace_of(ltype)]
        local["max_vel_x"] = max_vel_x
        if ltype == "dwa_local_planner/DWAPlannerROS":
            local["max_vel_trans"] = max_vel_x
    mb = dataclasses.replace(params.move_base, base_global_planner=gtype, base_local_planner=ltype)
    return dataclasses.replace(params, move_base=mb, namespaces=spaces)


def combination_key(world, global_kind, local_kind):
    """The JSON key of a closed loop: closed_loop_<world>[_<global>][_<local>], the
    course's NavFn and DWA left out (closed_loop_builtin is NavFn + DWA)."""
    key = "closed_loop_" + world
    if global_kind != "navfn":
        key += "_" + global_kind
    if local_kind != "dwa":
        key += "_" + local_kind.replace("-", "_")
    return key


def draw_pairs(params, world_yaml, n_runs, seed=0):
    """n_runs seeded start / goal poses on world_yaml, the same for every planner: free
    cells of the global costmap (static map, inflation), the robot's footprint clear of
    the walls at both, at least MIN_PAIR_DIST apart and connected (exact 8-connected grid
    geodesic through cells below the inscribed cost finite; a pair in a closed room is
    drawn again). [{"start": (x, y, yaw), "goal": (x, y, yaw), "geodesic_m", "sim_seed"}, ...]."""
    from summit_xl_sim.sim import Simulation
    from summit_xl_sim.world import World, WorldError
    world = World.from_yaml(world_yaml)
    cm = global_costmap(params, world.grid).master
    passable = cm.data < cv.INSCRIBED_INFLATED_OBSTACLE
    rng = np.random.default_rng(seed)
    free = np.argwhere(cm.data == cv.FREE_SPACE)
    pairs, k = [], -1
    while len(pairs) < n_runs:
        k += 1
        sim = Simulation(world, seed=seed * 1000 + k)   # only to check the poses: nothing moves
        while True:
            a = free[rng.integers(len(free))]
            sx, sy = cm.map_to_world(a[1], a[0])
            syaw = rng.uniform(-math.pi, math.pi)
            try:
                st = sim.add_robot("robot", sx, sy, syaw)
                break
            except WorldError:
                continue
        while True:
            b = free[rng.integers(len(free))]
            gx, gy = cm.map_to_world(b[1], b[0])
            gyaw = rng.uniform(-math.pi, math.pi)
            if math.hypot(gx - sx, gy - sy) >= MIN_PAIR_DIST and sim.blocked_by(st, (gx, gy, gyaw)) is None:
                break
        geo = grid_geodesic_length(passable, (a[1], a[0]), (b[1], b[0])) * cm.resolution
        if math.isfinite(geo):
            pairs.append({"start": (sx, sy, st.pose[2]), "goal": (gx, gy, gyaw), "geodesic_m": geo,
                          "sim_seed": seed * 1000 + k})
    return pairs


class SimCostmap:
    """One of move_base's costmaps over the simulator, as the node's CostmapROS over ROS.

    The LayeredCostmap the config describes (cfg: params.CostmapConfig; its static layers
    given the world's grid), updated at its update_frequency [Hz of simulated time] with
    the robot's latest scan added to every obstacle layer's sources, at the robot's true
    pose (perfect localization: the global and the local frame are both the world's). It
    is the handle the recoveries clear through (nav_core.PluginContext: layered, lock,
    get_robot_pose()).
    """

    def __init__(self, name, cfg, sim, robot, grid=None, log=None):
        self.name = name
        self.layered = build_costmap(cfg, name, log)
        self.lock = threading.RLock()
        self.sim, self.robot = sim, robot
        for layer in self.layered.layers:
            if isinstance(layer, StaticLayer):
                layer.set_map(grid.data, grid.resolution, grid.origin)
        self.obstacle_layers = [l for l in self.layered.layers if isinstance(l, ObstacleLayer)]
        # the node updates at update_frequency, or (at 0) until the first update succeeded
        self.period = 1.0 / cfg.update_frequency if cfg.update_frequency > 0 else None
        self.next_update = 0.0   # [s] of simulated time; None: no more updates

    def get_robot_pose(self):
        return self.robot.pose

    def due(self, now):
        return self.next_update is not None and now >= self.next_update - TIME_EPS

    def update(self, now, ranges):
        """Add the scan ranges (the robot's laser, now) and update the master at the robot's pose."""
        las = self.robot.laser
        laser_pose = self.sim.laser_pose(self.robot)
        for layer in self.obstacle_layers:
            for src in layer.sources.values():
                layer.add_observation(source_observation(src, ranges, las.angle_min, las.angle_increment,
                                                         las.range_min, las.range_max, laser_pose))
        self.layered.update_map(*self.robot.pose)
        self.next_update = now + self.period if self.period is not None else None


class MeteredLocalPlanner:
    """A local planner (nav_core.LocalPlanner) whose compute_velocity_commands is timed
    (ms: wall time [ms] of each call) and keeps its last result (last); everything else is
    the planner's own."""

    def __init__(self, planner):
        self.planner = planner
        self.ms = []
        self.last = None

    def compute_velocity_commands(self, pose, velocity, costmap):
        t0 = time.perf_counter()
        self.last = self.planner.compute_velocity_commands(pose, velocity, costmap)
        self.ms.append(1000.0 * (time.perf_counter() - t0))
        return self.last

    def __getattr__(self, name):
        return getattr(self.planner, name)


class CountedRecovery:
    """A recovery behaviour (nav_core.RecoveryBehavior) whose starts are listed by name in
    started; its steps are the behaviour's own."""

    def __init__(self, name, behaviour, started):
        self.name, self.behaviour, self.started = name, behaviour, started

    def start(self, pose, trail=()):
        self.started.append(self.name)
        self.behaviour.start(pose, trail)

    def step(self, pose, velocity, costmap):
        return self.behaviour.step(pose, velocity, costmap)


def drive_goal(p, world, pair, limit=None, trace=0.0, log=None):
    """One goal of the closed loop: move_base (MoveBaseCore, its plugins by type string
    through plugins.MoveBasePlugins, its two SimCostmaps) drives the simulated robot from
    pair["start"] to pair["goal"] in world (a summit_xl_sim World) with the parameters p
    (params.MoveBaseParams). The node's threads on simulated time, every control period
    (1 / controller_frequency) in this order: the costmaps due for an update take the
    current scan; the planner, when the core lets the planner thread plan (planner_wait:
    once per control cycle while PLANNING, 1 / planner_frequency after the last attempt
    began while CONTROLLING), plans on the global costmap from the robot's pose (planning
    takes no simulated time); then the core's cycle, whose command the simulator runs for
    the period. The goal is first checked as the node accepts it (move_base_core.accept_goal).
    limit: [s] of simulated time before the run is given up (default TIME_LIMIT_FACTOR x
    the first plan's length / max_vel_x, at least TIME_LIMIT_MIN); trace: print the
    state every trace [s] and the core's logs; log(text): where the costmaps' warnings
    go (default: the package's logger). Returns the run's figures (a dict; plans: the
    planning attempts)."""
    from summit_xl_sim.sim import Simulation
    (sx, sy, syaw), (gx, gy, gyaw) = pair["start"], pair["goal"]
    sim = Simulation(world, seed=pair["sim_seed"])
    st = sim.add_robot("robot", sx, sy, syaw)
    gcm = SimCostmap("global_costmap", p.global_costmap, sim, st, world.grid, log)
    lcm = SimCostmap("local_costmap", p.local_costmap, sim, st, log=log)
    plugins = MoveBasePlugins(p, gcm, lcm)
    planner = plugins.global_planner
    started = []   # the recovery behaviours' names, as each starts
    core = MoveBaseCore(p.move_base, lambda: MeteredLocalPlanner(plugins.make_local_planner()),
                        [(name, CountedRecovery(name, beh, started)) for name, beh in plugins.recoveries])
    period = 1.0 / p.move_base.controller_frequency
    sub = max(1, int(round(period / SIM_DT)))
    max_vel_x = plugins.local_planner.config.max_vel_x
    geodesic_optimal = pair["geodesic_m"] / max_vel_x
    given_limit = limit
    limit = limit if limit is not None else max(TIME_LIMIT_MIN, TIME_LIMIT_FACTOR * geodesic_optimal)
    trace_every = max(1, int(round(trace / period))) if trace else 0

    def say(t, logs):
        for _, text, _ in logs:
            print(f"    t={t:5.1f} move_base: {text}", flush=True)

    def update_costmaps(t):
        ranges = None
        for cm in (gcm, lcm):
            if cm.due(t):
                ranges = sim.scan("robot") if ranges is None else ranges
                with cm.lock:
                    cm.update(t, ranges)

    update_costmaps(0.0)
    end, first_len, modes, t_moving, fails, ms, plans = None, None, {}, None, 0, [], 0
    allow_unknown, tolerance = plugins.goal_tolerance()
    grids = [l.grid for l in gcm.layered.layers if isinstance(l, StaticLayer) and l.grid is not None]
    try:
        goal, note = accept_goal(gcm.layered.master, grids, (gx, gy, gyaw), allow_unknown, tolerance,
                                 gcm.layered.footprint.inscribed_radius)
        if note and trace:
            say(0.0, [(INFO, note, False)])
    except GoalError as e:
        goal, end = None, ("aborted", INVALID_GOAL + str(e))
    cycle, t = 0, 0.0
    if goal is not None:
        core.start_goal(goal, 0.0)
    while end is None:
        t = cycle * period
        if t >= limit - TIME_EPS:
            break
        if cycle:
            update_costmaps(t)
        request = core.begin_plan(t) if core.planner_wait(t) <= TIME_EPS else None
        if request is not None:
            r = planner.make_plan(gcm.layered.master, st.pose[:2], request[1][:2])
            logs = core.on_plan(request[0], r.path if r.ok else None, r.reason, t)
            plans += 1
            if r.ok and first_len is None:
                first_len = r.length
                if given_limit is None:
                    limit = max(TIME_LIMIT_MIN, TIME_LIMIT_FACTOR * first_len / max_vel_x)
            if trace:
                say(t, logs)
        pose, state = st.pose, core.state
        lp = core.local_planner
        n_calls = len(lp.ms)
        out = core.cycle(t, pose, pose, st.vel, lcm.layered.master, IDENTITY)
        ran = len(lp.ms) > n_calls
        mode = lp.last.mode if ran else state
        modes[mode] = modes.get(mode, 0.0) + sub * SIM_DT
        fails += int(ran and not lp.last.ok)
        if t_moving is None and st.vel[0] >= 0.5 * max_vel_x:
            t_moving = t
        if trace:
            say(t, out.logs)
            if cycle % trace_every == 0:
                res = lp.last if ran else None
                print(f"    t={t:5.1f} pose=({pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:.2f}) {core.state} mode={mode} "
                      + (f"ok={res.ok} cmd=({res.cmd[0]:.2f}, {res.cmd[2]:.2f}) valid={res.n_valid}/{res.n_samples} "
                         f"{res.reason}" if res is not None else f"cmd={out.cmd}"), flush=True)
        if out.end is not None:
            end = out.end
            break
        sim.command("robot", *(out.cmd if out.cmd is not None else (0.0, 0.0, 0.0)))
        hits = st.collisions
        for _ in range(sub):
            sim.step(SIM_DT)
        if trace and st.collisions > hits:
            print(f"    t={t:5.1f} COLLISION at pose=({st.pose[0]:.2f}, {st.pose[1]:.2f}, {st.pose[2]:.2f}) "
                  f"mode={mode} cmd={out.cmd} hit={st.last_hit}", flush=True)
        cycle += 1
    core.stop()
    if core.local_planner is not None:
        ms = core.local_planner.ms
    optimal = first_len / max_vel_x if first_len else geodesic_optimal
    err = math.hypot(st.pose[0] - gx, st.pose[1] - gy)
    yaw_err = abs(angle_diff(st.pose[2], gyaw))
    cfg = plugins.local_planner.config
    reached = end is not None and end[0] == "succeeded"
    ok = reached and err <= cfg.xy_goal_tolerance + 0.05 and yaw_err <= cfg.yaw_goal_tolerance + 0.05
    why = ("" if ok else "goal reported reached out of tolerance" if reached else
           f"aborted: {end[1]}" if end is not None else f"timeout ({limit:.0f} s)")
    return {"start": [sx, sy, syaw], "goal": [gx, gy, gyaw], "reached": bool(ok), "failure": why, "time_s": t,
            "plan_m": first_len, "plans": plans, "geodesic_m": pair["geodesic_m"], "ratio": t / optimal,
            "geodesic_ratio": t / geodesic_optimal, "collisions": st.collisions,
            "xy_error_m": err, "yaw_error_rad": yaw_err, "no_command_cycles": fails, "recoveries": len(started),
            "recovery_behaviors": started, "dwa_median_ms": float(np.median(ms)) if ms else None,
            "mode_s": modes, "t_moving_s": t_moving}


def closed_loop(params, world_yaml, n_runs, seed=0, verbose=False, only=None, trace=False, planner_kind="dwa",
                global_kind="navfn", pairs=None, max_vel_x=None):
    """Closed loop of one (global_kind, planner_kind) combination over n_runs seeded pairs
    (draw_pairs; pairs: already drawn ones): each pair one goal of move_base over the
    simulator (drive_goal), from a fresh start (robot, costmaps, plugins, core). only:
    run numbers (1-based) to simulate, the others skipped (to replay a failure); trace:
    print the controller's state every trace [s] of simulated time and move_base's logs."""
    from summit_xl_sim.world import World
    p = combination_params(params, global_kind, planner_kind, max_vel_x)
    pairs = pairs if pairs is not None else draw_pairs(p, world_yaml, n_runs, seed)
    plugins = MoveBasePlugins(p, footprint=build_costmap(p.local_costmap, "local_costmap").footprint)
    if verbose:
        for note in plugins.notes:    # what move_base would log once about the planners' parameters
            print(f"  {plugins.global_type} + {plugins.local_type}: {note}", flush=True)
    world = World.from_yaml(world_yaml)
    notes = []   # the costmaps' warnings, the same every run: said once

    def note(text):
        if text not in notes:
            notes.append(text)
            if verbose:
                print(f"  {text}", flush=True)

    runs = []
    for k, pair in enumerate(pairs):
        if only and k + 1 not in only:
            continue
        run = drive_goal(p, world, pair, trace=trace, log=note)
        runs.append(run)
        if verbose:
            plan = "-" if run["plan_m"] is None else f"{run['plan_m']:.1f}"
            print(f"  run {k + 1:3d}: reached={run['reached']} t={run['time_s']:5.1f}s ratio={run['ratio']:.2f} "
                  f"(geodesic {run['geodesic_ratio']:.2f}) coll={run['collisions']} err={run['xy_error_m']:.2f}m "
                  f"plan={plan}m geodesic={pair['geodesic_m']:.1f}m modes "
                  f"{ {m: round(v, 1) for m, v in run['mode_s'].items()} } moving at {run['t_moving_s']} "
                  f"recoveries {run['recovery_behaviors']} {run['failure']}", flush=True)
    return summarize({"world": world_yaml, "global_planner": global_kind, "local_planner": planner_kind,
                      "global_type": plugins.global_type, "local_type": plugins.local_type,
                      "max_vel_x": plugins.local_planner.config.max_vel_x}, runs)


HEADER_KEYS = ("world", "global_planner", "local_planner", "global_type", "local_type", "max_vel_x")


def summarize(header, runs):
    """One combination's figures over its runs (drive_goal records, in pair order);
    header: its HEADER_KEYS."""
    reached = [r for r in runs if r["reached"]]
    # Medians over every run: a run that failed counts with the time it was given up at.
    return {**{k: header[k] for k in HEADER_KEYS}, "runs": len(runs),
            "reached_share": len(reached) / max(1, len(runs)),
            "collisions": int(sum(r["collisions"] for r in runs)),
            "ratio_median": float(np.median([r["ratio"] for r in runs])) if runs else None,
            "geodesic_ratio_median": float(np.median([r["geodesic_ratio"] for r in runs])) if runs else None,
            "runs_detail": runs}


def matrix_table(results):
    """The compact table of closed-loop results [(world key, result), ...] as lines."""
    lines = [f"{'world':<8} {'global':<9} {'local':<15} {'reached':>8} {'coll':>5} "
             f"{'t/geodesic':>10} {'t/plan':>7} {'CPU s':>7}"]
    for name, c in results:
        geo, plan = c["geodesic_ratio_median"], c["ratio_median"]
        lines.append(f"{name:<8} {c['global_planner']:<9} {c['local_planner']:<15} "
                     f"{c['reached_share'] * 100:7.0f}% {c['collisions']:5d} "
                     f"{_r(geo):>10} {_r(plan):>7} {c.get('cpu_s', 0):7.0f}")
    return lines


def _r(x):
    return "-" if x is None else f"{x:.2f}"


def run_jobs(run, jobs, n_procs):
    """run(job) for each job, in order, as an iterator; n_procs at a time in forked
    children (run may be a closure: the children inherit it; only its result goes back,
    pickled)."""
    if n_procs <= 1 or len(jobs) <= 1:
        yield from (run(job) for job in jobs)
        return
    import multiprocessing
    global _FORKED_RUN
    _FORKED_RUN = run
    with multiprocessing.get_context("fork").Pool(n_procs) as pool:
        yield from pool.imap(_forked_run, jobs, chunksize=1)


def save_part(folder, key, commit, result):
    """Write one combination's result to folder/key.json (atomically), stamped with commit."""
    if not folder:
        return
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, key + ".json")
    with open(path + ".tmp", "w") as f:
        json.dump(dict(result, commit=commit), f, indent=1)
    os.replace(path + ".tmp", path)


def load_part(folder, key, commit):
    """The result save_part wrote for key, when it is from this commit (a clean tree); else None."""
    path = os.path.join(folder, key + ".json")
    if not os.path.exists(path) or not commit or commit.endswith("-dirty"):
        return None
    with open(path) as f:
        part = json.load(f)
    return part if part.get("commit") == commit else None


_FORKED_RUN = None


def _forked_run(job):
    return _FORKED_RUN(job)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=50, help="closed-loop runs on the built-in world")
    ap.add_argument("--willow-runs", type=int, default=0, help="closed-loop runs on willow-full-0.05")
    ap.add_argument("--navfn-pairs", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=1, help="repeats of the planner and DWA timings (median)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("-v", "--verbose", action="store_true")
    ap.add_argument("--only", type=int, nargs="*", help="simulate only these closed-loop run numbers")
    ap.add_argument("--trace", type=float, nargs="?", const=1.0, default=0.0,
                    help="print the controller state every this many simulated seconds (default 1)")
    ap.add_argument("--max-vel-x", type=float,
                    help="closed loop with this max_vel_x (and max_vel_trans) instead of the config's")
    ap.add_argument("--skip-navfn", action="store_true", help="skip the global planner and DWA-cycle benchmarks")
    ap.add_argument("--local-planner", choices=LOCAL_PLANNERS, default="dwa",
                    help="the closed loop's local planner (trajectory: base_local_planner's Trajectory "
                         "Rollout, trajectory-dwa: the same with dwa: true)")
    ap.add_argument("--global-planner", choices=GLOBAL_PLANNERS, default="navfn",
                    help="the closed loop's global planner (astar, dijkstra: global_planner/GlobalPlanner)")
    ap.add_argument("--matrix", action="store_true",
                    help="closed loop of every (global, local) planner combination over the same pairs")
    ap.add_argument("--jobs", type=int, default=1, help="closed-loop runs at a time (processes)")
    ap.add_argument("--parts", help="write each closed-loop combination here as <key>.json as soon as it is "
                                    "done (a stopped benchmark keeps the finished ones)")
    ap.add_argument("--resume", action="store_true",
                    help="take the combinations already in --parts from the same commit instead of running them")
    args = ap.parse_args(argv)
    if args.resume and not args.parts:
        ap.error("--resume needs --parts DIR")
    commit = git_commit(WORKSPACE)
    params = load_move_base_params(CONFIG)
    out = {"max_vel_x": combination_params(params, max_vel_x=args.max_vel_x).dwa.max_vel_x}
    if not args.skip_navfn:
        # Timings: the median over each repeat, then the median of those (load on a
        # shared machine varies between repeats); lengths are the same every repeat.
        cm = willow_costmap(params)
        pairs = far_pairs(cm, args.navfn_pairs, args.seed)
        repeats = max(1, args.repeats)
        navs, dijs, astars = [], [], []
        course = {k: v for k, v in params.namespace("NavfnROS").items() if k in COURSE_GLOBAL_PARAMS}
        for _ in range(repeats):  # interleaved, so that each planner sees the same load
            navs.append(bench_navfn(params, args.navfn_pairs, cm=cm, pairs=pairs))
            dijs.append(bench_global_planner(True, cm, pairs, course))
            astars.append(bench_global_planner(False, cm, pairs, course))
        for key, runs, name in (("navfn_willow", navs, "NavFn"),
                                ("global_planner_dijkstra_willow", dijs, "GlobalPlanner Dijkstra"),
                                ("global_planner_astar_willow", astars, "GlobalPlanner A*")):
            n = dict(runs[0])
            n["median_ms"] = float(np.median([r["median_ms"] for r in runs]))
            n["max_ms"] = float(np.median([r["max_ms"] for r in runs]))
            n["repeats_median_ms"] = [round(r["median_ms"], 1) for r in runs]
            n["cpu_median_ms"] = float(np.median([r["cpu_median_ms"] for r in runs]))
            out[key] = n
            extra = "" if "cells_expanded_median" not in n else \
                (f"; {n['cells_expanded_median']:.0f} cells expanded (median); with neutral_cost 255: path / "
                 f"geodesic median {n['geometric_length_ratio_median']:.3f}, max {n['geometric_length_ratio_max']:.3f}")
            print(f"{name} willow-full-0.05: median {n['median_ms']:.0f} ms wall, {n['cpu_median_ms']:.0f} ms CPU "
                  f"(repeats {n['repeats_median_ms']}; "
                  f"max {n['max_ms']:.0f}) over {n['pairs']} pairs; path / grid geodesic: median "
                  f"{n['length_ratio_median']:.3f} (min {n['length_ratio_min']:.3f}, max {n['length_ratio_max']:.3f}); "
                  f"median path {n['median_path_m']:.1f} m vs geodesic {n['median_geodesic_m']:.1f} m{extra}",
                  flush=True)
        dwas = [bench_dwa_cycle(params) for _ in range(max(1, args.repeats))]
        d = dict(dwas[0])
        d["median_ms"] = float(np.median([r["median_ms"] for r in dwas]))
        d["p90_ms"] = float(np.median([r["p90_ms"] for r in dwas]))
        d["repeats_median_ms"] = [round(r["median_ms"], 2) for r in dwas]
        d["cpu_median_ms"] = float(np.median([r["cpu_median_ms"] for r in dwas]))
        out["dwa_cycle"] = d
        print(f"DWA cycle: median {d['median_ms']:.2f} ms wall, {d['cpu_median_ms']:.2f} ms CPU "
              f"(repeats {d['repeats_median_ms']}), p90 "
              f"{d['p90_ms']:.2f} ms, {d['samples']} samples", flush=True)
    combos = [(g, loc) for g in GLOBAL_PLANNERS for loc in LOCAL_PLANNERS] if args.matrix \
        else [(args.global_planner, args.local_planner)]
    # One job per (combination, pair), so that every process stays busy to the end; the
    # pairs of a combination are merged in order as its last one is done.
    combos_todo, jobs = [], []   # (world, path, global_kind, local_kind, n_pairs); (combo index, pair index)
    for world, path in WORLDS:
        n_runs = {"builtin": args.runs, "willow": args.willow_runs}[world]
        if n_runs <= 0:
            continue
        pairs = draw_pairs(params, path, n_runs, args.seed)
        for g, loc in combos:
            key = combination_key(world, g, loc)
            part = load_part(args.parts, key, commit) if args.resume else None
            if part is not None:
                print(f"closed loop {key}: kept from {args.parts} (commit {part['commit']})", flush=True)
                out[key] = part
                continue
            ks = [k for k in range(len(pairs)) if not args.only or k + 1 in args.only]
            combos_todo.append((world, path, g, loc, pairs, len(ks)))
            jobs += [(len(combos_todo) - 1, k) for k in ks]

    def run(job):
        world, path, global_kind, local_kind, pairs, _ = combos_todo[job[0]]
        t0 = time.process_time()
        c = closed_loop(params, path, len(pairs), args.seed, args.verbose, [job[1] + 1], args.trace, local_kind,
                        global_kind, pairs, args.max_vel_x)
        c["cpu_s"] = time.process_time() - t0
        return c

    done, pieces, t_start = [], {}, time.time()
    for job, c in zip(jobs, run_jobs(run, jobs, args.jobs)):
        pieces.setdefault(job[0], []).append(c)
        world, path, global_kind, local_kind, _, n_pairs = combos_todo[job[0]]
        if len(pieces[job[0]]) < n_pairs:
            continue
        parts = pieces.pop(job[0])
        c = summarize(parts[0], [r for p in parts for r in p["runs_detail"]])
        c["cpu_s"] = sum(p["cpu_s"] for p in parts)
        c["wall_s"] = time.time() - t_start     # since the closed loops began (they overlap)
        print(f"closed loop {os.path.basename(path)} ({global_kind} + {local_kind}): "
              f"{c['reached_share'] * 100:.0f}% of {c['runs']} reached, {c['collisions']} collisions, "
              f"time / (L / max_vel_x) median: L geodesic {_r(c['geodesic_ratio_median'])}, "
              f"L plan {_r(c['ratio_median'])} ({c['cpu_s']:.0f} s CPU)", flush=True)
        key = combination_key(world, global_kind, local_kind)
        out[key] = c
        save_part(args.parts, key, commit, c)
        done.append((world, c))
    if len(done) > 1:
        print("\n".join(matrix_table(done)), flush=True)
    out["peak_rss_mb"] = peak_rss_mb()
    print(f"peak RSS {out['peak_rss_mb']:.0f} MB")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
