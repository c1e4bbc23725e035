#!/usr/bin/python3
"""Offline benchmark of the RBPF SLAM core on the simulator's tour, without ROS.

The ROS benchmark (bench_slam_sim.py) needs a master, the simulator node and the tour
driver, and takes minutes per run. This one drives the same tour in pure Python with
summit_xl_sim's core (as src/summit_xl_sim/test/test_world_and_tour.py does): the tour
controller at CONTROL_RATE, the simulator stepped by SIM_DT, and at LASER_RATE the laser
scan (laser frame, mount LaserParams.mount) with the odometry pose of that instant goes
to RbpfSlam, as slam_gmapping gets them. The run is judged with
my_summit_mapping.evaluation (ATE, map precision and recall against the true walls), the
same code the ROS benchmark uses, and the CPU time of the SLAM core per simulated second.

The simulated recordings (scans, odometry, ground truth) depend only on the simulator
seed and are cached as .npz in --cache, so a grid of simulator seeds x filter seeds
simulates each tour once.

Targets (issue 3): ATE <= 0.05 m, precision >= 0.95, recall >= 0.90, CPU <= 0.33 s per
simulated s, in every run.

Usage: slam_tour_offline.py [--sim-seeds 0 1 ...] [--filter-seeds 0 1 ...]
                            [--jobs 2] [--cache DIR] [--json PATH] [--set name=value ...]
"""
import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import yaml

from my_summit_mapping import evaluation
from my_summit_mapping.rbpf import RbpfSlam
from my_summit_mapping.slam_config import SlamConfig

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.abspath(os.path.join(HERE, "..", ".."))

WORLDS = os.path.join(SRC, "summit_xl_sim", "worlds")
WORLD_YAML = os.path.join(WORLDS, "course_building.yaml")
TOUR_YAML = os.path.join(WORLDS, "course_building_tour.yaml")
PARAMS_YAML = os.path.join(HERE, "..", "config", "gmapping_params.yaml")
SIM_DT = 0.005          # simulator step [s]
CONTROL_RATE = 20.0     # tour driver rate [Hz]
LASER_RATE = 40.0       # laser rate [Hz] (LaserParams.rate)
TOUR_TIMEOUT = 900.0    # give up on a tour after this much simulated time [s]
TARGETS = dict(ate_m=0.05, precision=0.95, recall=0.90, cpu_per_sim_s=0.33)  # issue 3
DEFAULT_CACHE = "/tmp/slam_tour_offline_cache"


def simulate_tour(sim_seed):
    """Drive the tour; returns dict(times (K,), ranges (K, n) float32, odom (K, 3),
    truth (K, 3)) at the laser's instants, plus the laser's angles, mount and range_max."""
    from summit_xl_sim.sim import Simulation
    from summit_xl_sim.tour import TourParams, tour_command
    from summit_xl_sim.world import World
    with open(TOUR_YAML) as f:
        tour = yaml.safe_load(f)
    sim = Simulation(World.from_yaml(WORLD_YAML), seed=sim_seed)
    state = sim.add_robot("r", *tour["start"])
    params = TourParams()
    control_every = int(round(1.0 / (CONTROL_RATE * SIM_DT)))
    laser_every = int(round(1.0 / (LASER_RATE * SIM_DT)))
    times, ranges, odom, truth = [], [], [], []
    i, n = 0, 0
    waypoints = tour["waypoints"]
    while i < len(waypoints) and sim.time < TOUR_TIMEOUT:
        if n % control_every == 0:
            vx, wz, reached = tour_command(params, state.pose, waypoints[i])
            if reached:
                i += 1
                continue
            sim.command("r", vx, 0.0, wz)
        if n % laser_every == 0:
            times.append(sim.time)
            ranges.append(sim.scan("r"))
            odom.append(state.odom_pose)
            truth.append(state.pose)
        sim.step(SIM_DT)
        n += 1
    if i < len(waypoints):
        raise RuntimeError(f"sim seed {sim_seed}: tour stuck before waypoint {i} at {state.pose}")
    return dict(times=np.array(times), ranges=np.array(ranges, np.float32), odom=np.array(odom),
                truth=np.array(truth), angles=state.laser.angles(), mount=np.array(state.laser.mount),
                range_max=state.laser.range_max, range_min=state.laser.range_min)


def load_tour(sim_seed, cache):
    """simulate_tour(sim_seed), from the cache when there."""
    from summit_xl_sim.sim import default_odom_model
    # The odometry model is part of the key: a tour cached under another model (the
    # simulator's default was ideal before odom_model existed) must not be reused.
    path = os.path.join(cache, f"tour_{sim_seed}_{default_odom_model('diff')}.npz") if cache else None
    if path and os.path.exists(path):
        with np.load(path) as z:
            return {k: z[k] for k in z.files}
    rec = simulate_tour(sim_seed)
    if path:
        os.makedirs(cache, exist_ok=True)
        tmp = path + f".{os.getpid()}.tmp.npz"
        np.savez(tmp, **rec)
        os.replace(tmp, path)
    return rec


def course_params(overrides=()):
    """The course's gmapping parameters (config/gmapping_params.yaml) with overrides."""
    with open(PARAMS_YAML) as f:
        params = yaml.safe_load(f)
    params.update(overrides)
    # slam_gmapping's default maxRange: the scan's range_max - 0.01 (set per run)
    return params


def run(sim_seed, filter_seed, cache, overrides=()):
    """One SLAM run on the tour of sim_seed with filter seed; returns a dict of figures."""
    from summit_xl_sim.world import World
    rec = load_tour(sim_seed, cache)
    params = course_params(dict(overrides))
    config = SlamConfig.from_dict({k: v for k, v in params.items() if k in SlamConfig.__dataclass_fields__})
    slam = RbpfSlam(config, np.random.default_rng(filter_seed))
    mount = tuple(float(v) for v in rec["mount"])
    angles = rec["angles"] + mount[2]
    ranges = rec["ranges"].astype(float)
    with np.errstate(invalid="ignore"):
        ranges[ranges < float(rec["range_min"])] = np.inf  # as slam_gmapping
    laser_in_base = (mount[0], mount[1], 0.0)
    cpu0 = time.process_time()
    for k in range(len(ranges)):
        slam.process(rec["odom"][k], ranges[k], angles, laser_in_base, timestamp=float(rec["times"][k]),
                     range_max=float(rec["range_max"]))
    cpu = time.process_time() - cpu0
    sim_s = float(rec["times"][-1] - rec["times"][0])
    world = World.from_yaml(WORLD_YAML)
    res = evaluation.evaluate(slam.trajectory(), slam.trajectory_times(), rec["times"], rec["truth"],
                              slam.occupancy_grid(), world, rec["mount"], rec["angles"], config.maxUrange)
    out = dict(sim_seed=sim_seed, filter_seed=filter_seed, ate_m=res["ate_m"],
               precision=res["precision"], recall=res["recall"], cpu_per_sim_s=cpu / sim_s,
               sim_s=sim_s, processed_scans=slam.update_count, resamples=slam.resample_count)
    out["ok"] = bool(out["ate_m"] <= TARGETS["ate_m"] and out["precision"] >= TARGETS["precision"]
                     and out["recall"] >= TARGETS["recall"])
    return out


def _parse_value(value):
    for cast in (int, float):
        try:
            return cast(value)
        except ValueError:
            pass
    return value


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sim-seeds", type=int, nargs="+", default=list(range(10)))
    parser.add_argument("--filter-seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--jobs", type=int, default=2, help="parallel processes")
    parser.add_argument("--cache", default=DEFAULT_CACHE, help="directory for simulated tours ('' = none)")
    parser.add_argument("--json", help="write the results as JSON to this path")
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE",
                        help="override a gmapping parameter")
    args = parser.parse_args(argv)
    overrides = tuple((k, _parse_value(v)) for k, v in (s.split("=", 1) for s in args.set))
    # simulate every tour once first (in parallel), then the SLAM runs
    with ProcessPoolExecutor(args.jobs) as pool:
        list(pool.map(load_tour, args.sim_seeds, [args.cache] * len(args.sim_seeds)))
        jobs = [(s, f) for s in args.sim_seeds for f in args.filter_seeds]
        futures = [pool.submit(run, s, f, args.cache, overrides) for s, f in jobs]
        print(f"{'sim':>4} {'filt':>4} {'ATE m':>7} {'prec':>6} {'recall':>6} {'cpu/s':>6} {'res':>4}  ok",
              flush=True)
        results = []
        for fut in futures:
            r = fut.result()
            results.append(r)
            print(f"{r['sim_seed']:4d} {r['filter_seed']:4d} {r['ate_m']:7.3f} {r['precision']:6.3f} "
                  f"{r['recall']:6.3f} {r['cpu_per_sim_s']:6.3f} {r['resamples']:4d}  "
                  f"{'ok' if r['ok'] else 'FAIL'}", flush=True)
    fails = sum(not r["ok"] for r in results)
    ates = np.array([r["ate_m"] for r in results])
    precs = np.array([r["precision"] for r in results])
    cpus = np.array([r["cpu_per_sim_s"] for r in results])
    print(f"failures {fails}/{len(results)}; ATE median {np.median(ates):.3f} max {ates.max():.3f} m; "
          f"precision min {precs.min():.3f}; CPU/sim s median {np.median(cpus):.3f} max {cpus.max():.3f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(overrides=dict(overrides), results=results), f, indent=2)
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
