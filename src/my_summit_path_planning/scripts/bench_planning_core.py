#!/usr/bin/env python3
"""Benchmark of the path-planning core (no ROS): NavFn, GlobalPlanner, one DWA cycle, closed loop.

1. NavFn, and global_planner/GlobalPlanner (default parameters) with Dijkstra and with
   A*, on willow-full-0.05 between the same far-apart free cells: median plan time over
   seeded pairs, and the path length against the exact 8-connected grid geodesic (for
   GlobalPlanner also with cost_factor 0.01: the path geometry alone).
2. One DWA control cycle (the course's sample counts) on a local costmap: median time.
3. Closed loop in summit_xl_sim.sim.Simulation with ground-truth pose: global costmap
   (static + obstacle + inflation) + NavFn (replanning at planner_frequency) + rolling
   local costmap from the laser + DWA, between seeded random free pose pairs; reports
   the share reached within tolerance, collisions, and the median of
   time-to-goal / (planned path length / max_vel_x). --local-planner trajectory (or
   trajectory-dwa) drives with base_local_planner's TrajectoryPlannerROS instead of DWA,
   configured as the course's navigation_stage lesson (TRAJECTORY_PARAMS).

Parameters come from the package's config/*.yaml. Usage:
  bench_planning_core.py [--runs 50] [--willow-runs 20] [--repeats 3] [--json PATH]
                         [--max-vel-x 1.5] [--local-planner dwa|trajectory|trajectory-dwa]
"""
import argparse
import json
import math
import os
import resource
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "src"))

from my_summit_path_planning import cost_values as cv  # noqa: E402
from my_summit_path_planning.dwa import DWAPlanner  # noqa: E402
from my_summit_path_planning.global_planner import GlobalPlanner, GlobalPlannerConfig  # noqa: E402
from my_summit_path_planning.layers import scan_to_observation  # noqa: E402
from my_summit_path_planning.navfn import NavFn, grid_geodesic_length  # noqa: E402
from my_summit_path_planning.params import build_costmap, load_move_base_params  # noqa: E402
from my_summit_path_planning.recovery import clear_costmap_layers  # noqa: E402
from my_summit_path_planning.trajectory_planner import TrajectoryPlanner  # noqa: E402

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
# TrajectoryPlannerROS as navigation_tutorials' navigation_stage/move_base_config/
# base_local_planner_params.yaml sets it (the course's multi-robot lesson), deprecated
# names and all, but holonomic_robot false: the simulated Summit XL drives as a diff
# drive unless told otherwise. dwa comes from --local-planner.
TRAJECTORY_PARAMS = {
    "acc_lim_th": 3.2, "acc_lim_x": 2.5, "acc_lim_y": 2.5, "max_vel_x": 0.65, "min_vel_x": 0.1,
    "max_rotational_vel": 1.0, "min_in_place_rotational_vel": 0.4, "backup_vel": -0.1,
    "holonomic_robot": False, "y_vels": [-0.3, -0.1, 0.1, -0.3], "xy_goal_tolerance": 0.1,
    "yaw_goal_tolerance": 0.05, "sim_time": 1.7, "sim_granularity": 0.025, "vx_samples": 3,
    "vtheta_samples": 20, "goal_distance_bias": 0.8, "path_distance_bias": 0.6, "occdist_scale": 0.01,
    "heading_lookahead": 0.325, "oscillation_reset_dist": 0.05, "prune_plan": True}
LOCAL_PLANNERS = ("dwa", "trajectory", "trajectory-dwa")


def local_planner(kind, params, footprint):
    """The closed loop's local planner: DWAPlanner from config/, or TrajectoryPlanner
    (TRAJECTORY_PARAMS, dwa: false for 'trajectory', true for 'trajectory-dwa')."""
    if kind == "dwa":
        return DWAPlanner(params.dwa, footprint)
    return TrajectoryPlanner.from_params(dict(TRAJECTORY_PARAMS, dwa=kind == "trajectory-dwa"), footprint,
                                         controller_frequency=params.move_base.controller_frequency)


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


def bench_global_planner(use_dijkstra, cm, pairs):
    """global_planner/GlobalPlanner with its default parameters (A* when not use_dijkstra),
    plus the same plans with cost_factor 0.01 (the path geometry without the costs)."""
    planner = GlobalPlanner(GlobalPlannerConfig(use_dijkstra=use_dijkstra))
    out = bench_plans(planner, cm, pairs, "GlobalPlanner")
    cells = []
    for a, b, _ in pairs:
        planner.make_plan(cm, cm.map_to_world(a[1], a[0]), cm.map_to_world(b[1], b[0]))
        cells.append(planner.cells_expanded)
    out["cells_expanded_median"] = float(np.median(cells))
    geometric = bench_plans(GlobalPlanner(GlobalPlannerConfig(use_dijkstra=use_dijkstra, cost_factor=0.01)),
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


def closed_loop(params, world_yaml, n_runs, seed=0, verbose=False, only=None, trace=False, planner_kind="dwa"):
    """only: run numbers (1-based) to simulate, the others are drawn but skipped (to
    replay a failure); trace: print the controller's state every trace [s] of simulated time;
    planner_kind: one of LOCAL_PLANNERS."""
    from summit_xl_sim.sim import Simulation
    from summit_xl_sim.world import World, WorldError
    world = World.from_yaml(world_yaml)
    g = global_costmap(params, world.grid)
    cm = g.master
    planner = NavFn(params.navfn)
    cfg = params.dwa
    period = 1.0 / params.move_base.controller_frequency
    sub = max(1, int(round(period / SIM_DT)))
    replan_every = int(round(1.0 / (params.move_base.planner_frequency * period))) \
        if params.move_base.planner_frequency > 0 else 0
    rng = np.random.default_rng(seed)
    free = np.argwhere(cm.data == cv.FREE_SPACE)
    runs = []
    for k in range(n_runs):
        sim = Simulation(World.from_yaml(world_yaml), seed=seed * 1000 + k)
        while True:
            a = free[rng.integers(len(free))]
            sx, sy = cm.map_to_world(a[1], a[0])
            try:
                st = sim.add_robot("robot", sx, sy, rng.uniform(-math.pi, math.pi))
                break
            except WorldError:
                continue
        while True:
            b = free[rng.integers(len(free))]
            gx, gy = cm.map_to_world(b[1], b[0])
            gyaw = rng.uniform(-math.pi, math.pi)
            if math.hypot(gx - sx, gy - sy) >= MIN_PAIR_DIST and sim.blocked_by(st, (gx, gy, gyaw)) is None:
                break
        first = planner.make_plan(cm, (sx, sy), (gx, gy))
        if not first.ok:   # unreachable pair (closed room): draw another, not a failure
            continue
        if only and len(runs) + 1 not in only:
            runs.append(None)
            continue
        loc = build_costmap(params.local_costmap, "local_costmap")
        g_obs = g.layer("obstacle_layer")
        g_obs.reset()
        dwa = local_planner(planner_kind, params, loc.footprint)
        cfg = dwa.config
        dwa.set_plan(first.path, gyaw)
        las = st.laser
        optimal = first.length / cfg.max_vel_x
        limit = max(TIME_LIMIT_MIN, TIME_LIMIT_FACTOR * optimal)
        t, cycle, reached, fails, dwa_ms, stuck, recoveries = 0.0, 0, False, 0, [], 0, 0
        modes = {}          # [s] of simulated time per DWA mode (where the time goes)
        t_moving = None     # [s] first time the robot drives faster than half max_vel_x
        while t < limit:
            pose = st.pose
            ranges = sim.scan("robot")
            obs_args = (ranges, las.angle_min, las.angle_increment, las.range_min, las.range_max,
                        sim.laser_pose(st), True)
            loc.layer("obstacle_layer").add_observation(scan_to_observation(*obs_args, 4.0, 4.5))
            loc.update_map(*pose)
            if replan_every and cycle % replan_every == 0 and cycle > 0:
                g_obs.add_observation(scan_to_observation(*obs_args, 4.0, 4.5))
                g.update_map(*pose)
                r = planner.make_plan(cm, pose[:2], (gx, gy))
                if r.ok and not dwa.xy_latched:
                    dwa.set_plan(r.path, gyaw)
            t0 = time.perf_counter()
            res = dwa.compute_velocity(pose, st.vel, loc.master)
            dwa_ms.append(1000 * (time.perf_counter() - t0))
            modes[res.mode] = modes.get(res.mode, 0.0) + sub * SIM_DT
            if t_moving is None and st.vel[0] >= 0.5 * cfg.max_vel_x:
                t_moving = t
            if res.goal_reached:
                reached = True
                break
            if not res.ok:
                fails += 1
                stuck += 1
                if stuck * period >= params.move_base.controller_patience:
                    # move_base would start its recoveries here: the aggressive reset of the
                    # obstacle layers (the rotations are left to the node), then a new plan.
                    clear_costmap_layers(loc, pose[:2], 0.0, ("obstacle_layer",), force_clear_all=True)
                    recoveries += 1
                    stuck = 0
                    r = planner.make_plan(cm, pose[:2], (gx, gy))
                    if r.ok:
                        dwa.set_plan(r.path, gyaw)
            else:
                stuck = 0
            if trace and cycle % max(1, int(round(trace / period))) == 0:
                print(f"    t={t:5.1f} pose=({pose[0]:.2f}, {pose[1]:.2f}, {pose[2]:.2f}) mode={res.mode} "
                      f"ok={res.ok} cmd=({res.cmd[0]:.2f}, {res.cmd[2]:.2f}) valid={res.n_valid}/{res.n_samples} "
                      f"{res.reason}", flush=True)
            sim.command("robot", *res.cmd)
            for _ in range(sub):
                sim.step(SIM_DT)
            t += sub * SIM_DT
            cycle += 1
        err = math.hypot(st.pose[0] - gx, st.pose[1] - gy)
        yaw_err = abs((st.pose[2] - gyaw + math.pi) % (2 * math.pi) - math.pi)
        ok = reached and err <= cfg.xy_goal_tolerance + 0.05 and yaw_err <= cfg.yaw_goal_tolerance + 0.05
        run = {"start": [sx, sy], "goal": [gx, gy, gyaw], "reached": bool(ok), "time_s": t,
               "plan_m": first.length, "ratio": t / optimal, "collisions": st.collisions,
               "xy_error_m": err, "yaw_error_rad": yaw_err, "no_command_cycles": fails, "recoveries": recoveries,
               "dwa_median_ms": float(np.median(dwa_ms)), "mode_s": modes, "t_moving_s": t_moving}
        runs.append(run)
        if verbose:
            print(f"  run {len(runs):3d}: reached={ok} t={t:5.1f}s ratio={run['ratio']:.2f} "
                  f"coll={st.collisions} err={err:.2f}m plan={first.length:.1f}m modes "
                  f"{ {k: round(v, 1) for k, v in modes.items()} } moving at {t_moving}", flush=True)
    runs = [r for r in runs if r is not None]
    reached = [r for r in runs if r["reached"]]
    return {"world": world_yaml, "local_planner": planner_kind, "runs": len(runs),
            "reached_share": len(reached) / max(1, len(runs)),
            "collisions": int(sum(r["collisions"] for r in runs)),
            # Over every run: a run that failed counts with the time it was given up at.
            "ratio_median": float(np.median([r["ratio"] for r in runs])) if runs else None,
            "runs_detail": runs}


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
    args = ap.parse_args(argv)
    params = load_move_base_params(CONFIG)
    if args.max_vel_x:
        params.dwa.max_vel_x = params.dwa.max_vel_trans = args.max_vel_x
    out = {"max_vel_x": params.dwa.max_vel_x}
    if not args.skip_navfn:
        # Timings: the median over each repeat, then the median of those (load on a
        # shared machine varies between repeats); lengths are the same every repeat.
        cm = willow_costmap(params)
        pairs = far_pairs(cm, args.navfn_pairs, args.seed)
        repeats = max(1, args.repeats)
        navs, dijs, astars = [], [], []
        for _ in range(repeats):  # interleaved, so that each planner sees the same load
            navs.append(bench_navfn(params, args.navfn_pairs, cm=cm, pairs=pairs))
            dijs.append(bench_global_planner(True, cm, pairs))
            astars.append(bench_global_planner(False, cm, pairs))
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
                (f"; {n['cells_expanded_median']:.0f} cells expanded (median); with cost_factor 0.01: path / "
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
    for key, path, n_runs in (("closed_loop_builtin", BUILTIN, args.runs),
                              ("closed_loop_willow", WILLOW, args.willow_runs)):
        if n_runs <= 0:
            continue
        t0 = time.time()
        c = closed_loop(params, path, n_runs, args.seed, args.verbose, args.only, args.trace, args.local_planner)
        c["wall_s"] = time.time() - t0
        if args.local_planner != "dwa":
            key += "_" + args.local_planner.replace("-", "_")
        out[key] = c
        print(f"closed loop {os.path.basename(path)} ({args.local_planner}): "
              f"{c['reached_share'] * 100:.0f}% of {c['runs']} reached, "
              f"{c['collisions']} collisions, time/(plan/max_vel_x) median "
              f"{c['ratio_median'] if c['ratio_median'] is None else round(c['ratio_median'], 2)} "
              f"({c['wall_s']:.0f} s wall)", flush=True)
    out["peak_rss_mb"] = peak_rss_mb()
    print(f"peak RSS {out['peak_rss_mb']:.0f} MB")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
