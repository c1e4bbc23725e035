#!/usr/bin/env python3
"""Benchmark of the amcl core (no ROS): update cost, tracking, global localization, kidnapping.

1. Cost: median time of one filter update (motion + likelihood-field sensor + KLD
   low-variance resample; then also with the cluster estimate the node asks for) with
   5000 particles (min = max = 5000) and amcl's subsampling of the 1081-beam scan with
   laser_max_beams=60 (61 beams), on the built-in map and on willow-full-0.05. The
   machine's load is printed beside it: the figures are wall-clock times.
2. Tracking: the simulator (summit_xl_sim.sim.Simulation) drives the course tour at
   20 Hz control with 0.005 s steps; the filter gets odometry (state.odom_pose) and
   scans at 10 Hz, starting from the known pose; the estimate at each tick is
   map->odom (+) odom (what amcl's tf gives), compared with ground truth after the
   first 5 s: position and yaw RMSE.
3. Global localization from 20 seeded random free poses: the robot wanders (a reactive
   laser driver on ground truth); converged when the estimate stays within 0.2 m and
   10 deg for 1 s, within 15 m of driving.
4. Kidnapping (10 runs): tracking from the known pose, after 3 m the robot is teleported
   (sim.set_pose; odometry does not see it) to a random free pose >= 3 m away; recovered
   when the estimate stays within 0.2 m and 10 deg for 1 s within 15 m of driving after.
   With recovery_global_only false (random particles while tracking, as amcl): the
   course's YAML injects them only while globally localizing, so a kidnapped robot there
   needs /global_localization (section 3).

Parameters: config/amcl_params.yaml (amcl names). Usage:
    bench_amcl_core.py [--json PATH] [--quick] [--params YAML] [--only cost|tracking|global|kidnap]

JSON written by --json (for tools/bench.py; every section present only when run):
  params (str), load_average [1, 5, 15 min], peak_rss_mb (whole run) [MB],
  cost: list per map of {map, particles, beams, median_ms, p90_ms,
        with_estimate_median_ms, stages_median_ms {motion, sensor, resample, estimate},
        peak_rss_mb},
  tracking: {position_rmse_m, yaw_rmse_deg, position_max_m, yaw_max_deg, samples,
        completed_tour, sim_time_s, collisions, mean_particles, filter_time_per_scan_ms,
        wall_s, peak_rss_mb},
  global: {runs, converged, details [...], wall_s, peak_rss_mb},
  kidnap: {runs, recovered, recovery_global_only (false), details [...], wall_s, peak_rss_mb}.
"""
import argparse
import dataclasses
import json
import math
import os
import resource
import sys
import time

import numpy as np
import yaml

from summit_nav_common.geometry import pose_error
from summit_nav_common.map_io import load_map
from summit_xl_sim.sim import Simulation
from summit_xl_sim.tour import TourParams, tour_command
from summit_xl_sim.world import World

from my_summit_localization.amcl_config import AmclConfig
from my_summit_localization.particle_filter import ParticleFilter

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)

SIM_PKG = os.path.join(os.path.dirname(PKG), "summit_xl_sim")
BUILTIN = os.path.join(SIM_PKG, "worlds", "course_building.yaml")
TOUR = os.path.join(SIM_PKG, "worlds", "course_building_tour.yaml")
WILLOW = os.path.normpath(os.path.join(PKG, "..", "..", "data", "maps", "willow-full-0.05.yaml"))

SIM_DT = 0.005          # simulator step [s]
CONTROL_EVERY = 10      # steps per control command (20 Hz)
SCAN_EVERY = 20         # steps per filter input (10 Hz)
SETTLE_TIME = 5.0       # tracking: RMSE counted after this time [s]
POS_TOL = 0.2           # convergence: position tolerance [m]
YAW_TOL = math.radians(10.0)  # convergence: yaw tolerance [rad]
HOLD_TICKS = 10         # convergence must hold this many 10 Hz ticks (1 s)
DRIVE_BUDGET = 15.0     # driving allowed to converge [m]
ROBOT = "r"


def peak_rss_mb():
    """Peak resident memory of this process so far [MB] (ru_maxrss is in KiB on Linux)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def load_params(path):
    with open(path) as f:
        doc = yaml.safe_load(f) or {}
    return AmclConfig.from_dict(doc)


# -- 1. cost of one update --------------------------------------------------------------
def free_pose_with_clearance(world, rng, clearance=0.8):
    """A random pose whose cell is at least `clearance` [m] from walls."""
    free = np.argwhere((world.grid.data == 0) & (world.dist * world.resolution >= clearance))
    row, col = free[rng.integers(len(free))]
    x, y = world.grid.cell_to_world(col, row)
    return x, y, rng.uniform(-math.pi, math.pi)


def bench_update_cost(map_path, cfg, runs=60, n=5000, max_beams=60):
    """Median / p90 time [ms] of ParticleFilter.update with n particles (stage times too)."""
    grid = load_map(map_path)
    world = World(grid)
    rng = np.random.default_rng(1)
    c = AmclConfig.from_dict({**vars(cfg), "min_particles": n, "max_particles": n,
                              "laser_max_beams": max_beams, "resample_interval": 1,
                              "update_min_d": 0.0, "update_min_a": 0.0,
                              "laser_model_type": "likelihood_field"})
    x, y, yaw = free_pose_with_clearance(world, rng)
    angles = np.linspace(-2.356194490192345, 2.356194490192345, 1081)
    mount = (0.25, 0.0, 0.0)
    lx, ly = x + 0.25 * math.cos(yaw), y + 0.25 * math.sin(yaw)
    ranges = world.cast(lx, ly, angles + yaw, 30.0)
    ranges[ranges >= 30.0] = np.inf
    pf = ParticleFilter(c, grid, np.random.default_rng(2))
    pf.set_pose((x, y, yaw), np.diag([0.1, 0.1, 0.05]))
    odom = np.zeros(3)
    pf.update(odom, ranges, angles, mount, 0.1, 30.0)
    times, with_estimate = [], []
    for k in range(runs):
        odom = odom + np.array([0.01, 0.0, 0.0])  # a move: the motion model runs
        t0 = time.perf_counter()
        pf.update(odom, ranges, angles, mount, 0.1, 30.0)
        t1 = time.perf_counter()
        pf.map_to_odom()  # the node asks for the estimate (clustering) after each update
        t2 = time.perf_counter()
        times.append(t1 - t0)
        with_estimate.append(t2 - t0)
        assert pf.n == n and pf.resampled
    # stages, for the report
    stage = {"motion": [], "sensor": [], "resample": [], "estimate": []}
    for k in range(runs // 2):
        t0 = time.perf_counter()
        pf.apply_motion(np.array([0.01, 0.0, 0.0]), 0.0)
        t1 = time.perf_counter()
        pf.apply_scan(ranges, angles, mount, 0.1, 30.0)
        t2 = time.perf_counter()
        pf.resample()
        t3 = time.perf_counter()
        pf.estimate()
        t4 = time.perf_counter()
        for key, dt in zip(stage, (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
            stage[key].append(dt)
    beams = len(range(0, 1081, max(1, 1080 // (max_beams - 1))))
    return {"map": os.path.basename(map_path), "particles": n, "beams": beams,
            "median_ms": 1e3 * float(np.median(times)),
            "p90_ms": 1e3 * float(np.percentile(times, 90)),
            "with_estimate_median_ms": 1e3 * float(np.median(with_estimate)),
            "stages_median_ms": {k: 1e3 * float(np.median(v)) for k, v in stage.items()}}


# -- drivers ------------------------------------------------------------------------
class Wanderer:
    """Reactive exploration on the true scan: head for the most open direction ahead,
    turn in place away from close obstacles (hysteresis so it does not dither)."""

    def __init__(self, rng):
        self.rng = rng
        self.turning = 0.0
        self.goal_bearing = 0.0

    def command(self, ranges, angles):
        r = np.where(np.isfinite(ranges), ranges, 30.0)
        front = r[np.abs(angles) < math.radians(35)].min()
        near = r[np.abs(angles) < math.radians(100)].min()
        if self.turning:
            if front > 1.6 and near > 0.45:
                self.turning = 0.0
            else:
                return 0.0, self.turning
        if front < 0.9 or near < 0.35:
            left = r[(angles > 0.3) & (angles < 2.0)].mean()
            right = r[(angles < -0.3) & (angles > -2.0)].mean()
            self.turning = 0.8 if left >= right else -0.8
            return 0.0, self.turning
        # Most open direction within +-70 deg (smoothed ranges), a little randomness.
        sel = np.abs(angles) < math.radians(70)
        sm = np.convolve(r, np.ones(41) / 41, mode="same")
        k = np.argmax(np.where(sel, sm, -1.0))
        target = angles[k] + self.rng.normal(0.0, 0.1)
        self.goal_bearing = 0.7 * self.goal_bearing + 0.3 * target
        wz = float(np.clip(1.2 * self.goal_bearing, -0.8, 0.8))
        vx = float(np.clip(0.35 * (front - 0.6), 0.1, 0.6)) * max(0.2, math.cos(self.goal_bearing))
        return vx, wz


def feed(pf, sim, state):
    """One filter input: odometry + scan at the current sim time."""
    ranges = sim.scan(ROBOT)
    pf.update(state.odom_pose, ranges, state.laser.angles(), state.laser.mount,
              state.laser.range_min, state.laser.range_max)
    return ranges


# -- 2. tracking ----------------------------------------------------------------------
def bench_tracking(cfg, seed=0, until=600.0, on_step=None):
    """The tour from the known pose, to its end or `until` [s] of simulated time;
    on_step(sim, state), when given, runs every simulator step before the filter's input
    (a test changes the world there)."""
    world = World.from_yaml(BUILTIN)
    with open(TOUR) as f:
        tour = yaml.safe_load(f)
    sim = Simulation(world, seed=seed)
    state = sim.add_robot(ROBOT, *tour["start"])
    pf = ParticleFilter(cfg, world.grid, np.random.default_rng(seed))
    pf.set_pose(tour["start"], cfg.initial_cov())
    params = TourParams()
    waypoints = tour["waypoints"]
    i, n = 0, 0
    pos_err, yaw_err, times, particles = [], [], [], []
    t_filter = 0.0
    while i < len(waypoints) and sim.time < until:
        if n % CONTROL_EVERY == 0:
            vx, wz, reached = tour_command(params, state.pose, waypoints[i])
            if reached:
                i += 1
                continue
            sim.command(ROBOT, vx, 0.0, wz)
        if on_step is not None:
            on_step(sim, state)
        if n % SCAN_EVERY == 0:
            t0 = time.perf_counter()
            feed(pf, sim, state)
            t_filter += time.perf_counter() - t0
            est = pf.pose_at(state.odom_pose)
            if sim.time > SETTLE_TIME:
                e_pos, e_yaw = pose_error(est, state.pose)
                pos_err.append(e_pos)
                yaw_err.append(e_yaw)
                times.append(sim.time)
            particles.append(pf.n)
        sim.step(SIM_DT)
        n += 1
    pos_err, yaw_err = np.array(pos_err), np.array(yaw_err)
    return {"completed_tour": i == len(waypoints), "sim_time_s": sim.time,
            "collisions": state.collisions, "samples": int(pos_err.size),
            "position_rmse_m": float(np.sqrt(np.mean(pos_err ** 2))),
            "yaw_rmse_deg": math.degrees(float(np.sqrt(np.mean(yaw_err ** 2)))),
            "position_max_m": float(pos_err.max()),
            "yaw_max_deg": math.degrees(float(yaw_err.max())),
            "mean_particles": float(np.mean(particles)),
            "filter_time_per_scan_ms": 1e3 * t_filter / max(1, len(particles))}


# -- 3. / 4. global localization and kidnapping ----------------------------------------
def spawn_pose(sim, world, rng, clearance=0.7, away_from=None, min_dist=0.0):
    """A random free pose where the robot fits (and >= min_dist from away_from)."""
    for _ in range(1000):
        x, y, yaw = free_pose_with_clearance(world, rng, clearance)
        if away_from is not None and math.hypot(x - away_from[0], y - away_from[1]) < min_dist:
            continue
        if sim.blocked_by(sim.robots[ROBOT], (x, y, yaw)) is None:
            return x, y, yaw
    raise RuntimeError("no free spawn pose found")


def run_until_converged(pf, sim, state, rng, budget, stop_when_converged=True, driver=None):
    """Wander and feed the filter; returns (converged, driven [m], sim time used [s]).

    stop_when_converged False: drive the whole budget; converged then says whether the
    estimate was within tolerance (held for 1 s) at the end."""
    driver = driver or Wanderer(rng)
    driven, hold, n, t_start = 0.0, 0, 0, sim.time
    last = state.pose
    ranges = sim.scan(ROBOT)
    angles = state.laser.angles()
    while driven < budget:
        if n % CONTROL_EVERY == 0:
            vx, wz = driver.command(ranges, angles)
            sim.command(ROBOT, vx, 0.0, wz)
        if n % SCAN_EVERY == 0:
            ranges = feed(pf, sim, state)
            e_pos, e_yaw = pose_error(pf.pose_at(state.odom_pose), state.pose)
            hold = hold + 1 if (e_pos < POS_TOL and e_yaw < YAW_TOL) else 0
            if hold >= HOLD_TICKS and stop_when_converged:
                return True, driven, sim.time - t_start
        sim.step(SIM_DT)
        n += 1
        driven += math.hypot(state.pose[0] - last[0], state.pose[1] - last[1])
        last = state.pose
        if sim.time - t_start > 300.0:  # stuck driver: give up
            break
    return (not stop_when_converged and hold >= HOLD_TICKS), driven, sim.time - t_start


def bench_global(cfg, runs=20, seed=100):
    world = World.from_yaml(BUILTIN)
    results = []
    for k in range(runs):
        rng = np.random.default_rng([seed, k])
        sim = Simulation(world, seed=seed + k)
        sim.add_robot(ROBOT, 2.0, 7.0, 0.0)
        x, y, yaw = spawn_pose(sim, world, rng)
        sim.set_pose(ROBOT, x, y, yaw)
        state = sim.robots[ROBOT]
        pf = ParticleFilter(cfg, world.grid, np.random.default_rng([seed, k, 1]))
        pf.global_localization()
        ok, driven, used = run_until_converged(pf, sim, state, rng, DRIVE_BUDGET)
        results.append({"start": [round(x, 2), round(y, 2), round(yaw, 3)], "converged": ok,
                         "driven_m": round(driven, 2), "sim_time_s": round(used, 1)})
    return {"runs": runs, "converged": sum(r["converged"] for r in results), "details": results}


def bench_kidnap(cfg, runs=10, seed=200, before=3.0):
    """Automatic recovery from a kidnapping needs random particles while tracking: run with
    recovery_global_only false (amcl's augmented MCL), whatever the YAML says."""
    cfg = dataclasses.replace(cfg, recovery_global_only=False)
    world = World.from_yaml(BUILTIN)
    with open(TOUR) as f:
        start = yaml.safe_load(f)["start"]
    results = []
    for k in range(runs):
        rng = np.random.default_rng([seed, k])
        sim = Simulation(world, seed=seed + k)
        state = sim.add_robot(ROBOT, *start)
        pf = ParticleFilter(cfg, world.grid, np.random.default_rng([seed, k, 1]))
        pf.set_pose(start, cfg.initial_cov())
        driver = Wanderer(rng)
        ok0, _, _ = run_until_converged(pf, sim, state, rng, before, stop_when_converged=False,
                                        driver=driver)  # track for a while
        x, y, yaw = spawn_pose(sim, world, rng, away_from=state.pose, min_dist=3.0)
        sim.set_pose(ROBOT, x, y, yaw)
        ok, driven, used = run_until_converged(pf, sim, state, rng, DRIVE_BUDGET, driver=driver)
        results.append({"to": [round(x, 2), round(y, 2), round(yaw, 3)], "tracked_before": ok0,
                        "recovered": ok, "driven_m": round(driven, 2), "sim_time_s": round(used, 1)})
    return {"runs": runs, "recovered": sum(r["recovered"] for r in results), "recovery_global_only": False,
            "details": results}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the results as JSON to this path")
    ap.add_argument("--params", default=os.path.join(PKG, "config", "amcl_params.yaml"))
    ap.add_argument("--quick", action="store_true", help="fewer runs (5 global, 3 kidnap)")
    ap.add_argument("--only", choices=["cost", "tracking", "global", "kidnap"], action="append")
    args = ap.parse_args(argv)
    cfg = load_params(args.params)
    only = set(args.only or ["cost", "tracking", "global", "kidnap"])
    out = {"params": args.params}
    if "cost" in only:
        out["load_average"] = os.getloadavg()
        print(f"load average {out['load_average'][0]:.2f} on {os.cpu_count()} CPUs", flush=True)
        out["cost"] = []
        for path in (BUILTIN, WILLOW):
            r = bench_update_cost(path, cfg)
            r["peak_rss_mb"] = peak_rss_mb()
            out["cost"].append(r)
        for r in out["cost"]:
            print(f"update cost {r['map']:<28} {r['particles']} particles x {r['beams']} beams: "
                  f"median {r['median_ms']:.2f} ms (p90 {r['p90_ms']:.2f}; with estimate "
                  f"{r['with_estimate_median_ms']:.2f}) stages "
                  + ", ".join(f"{k} {v:.2f}" for k, v in r["stages_median_ms"].items()), flush=True)
    if "tracking" in only:
        t0 = time.time()
        r = out["tracking"] = bench_tracking(cfg)
        r["wall_s"], r["peak_rss_mb"] = time.time() - t0, peak_rss_mb()
        print(f"tracking: position RMSE {r['position_rmse_m']:.4f} m (max {r['position_max_m']:.3f}), "
              f"yaw RMSE {r['yaw_rmse_deg']:.2f} deg (max {r['yaw_max_deg']:.2f}), "
              f"{r['samples']} samples, tour completed {r['completed_tour']}, "
              f"mean particles {r['mean_particles']:.0f} [{time.time() - t0:.0f} s]", flush=True)
    if "global" in only:
        t0 = time.time()
        r = out["global"] = bench_global(cfg, runs=5 if args.quick else 20)
        r["wall_s"], r["peak_rss_mb"] = time.time() - t0, peak_rss_mb()
        print(f"global localization: {r['converged']}/{r['runs']} converged within "
              f"{DRIVE_BUDGET:.0f} m; driven " + " ".join(
                  f"{d['driven_m']:.1f}" + ("" if d["converged"] else "x") for d in r["details"])
              + f" [{time.time() - t0:.0f} s]", flush=True)
    if "kidnap" in only:
        t0 = time.time()
        r = out["kidnap"] = bench_kidnap(cfg, runs=3 if args.quick else 10)
        r["wall_s"], r["peak_rss_mb"] = time.time() - t0, peak_rss_mb()
        print(f"kidnapping: {r['recovered']}/{r['runs']} recovered within {DRIVE_BUDGET:.0f} m; "
              "driven " + " ".join(f"{d['driven_m']:.1f}" + ("" if d["recovered"] else "x")
                                   for d in r["details"]) + f" [{time.time() - t0:.0f} s]", flush=True)
    out["peak_rss_mb"] = peak_rss_mb()
    print(f"peak resident memory {out['peak_rss_mb']:.0f} MB", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
