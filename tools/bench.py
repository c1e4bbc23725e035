#!/usr/bin/python3
"""`make bench`: performance benchmarks, printed as a table and written as JSON.

Benchmarks measure; they do not pass or fail (the tests stay free of wall-clock
thresholds). Each figure is the median of several runs; peak resident memory is given
beside each time. Sections:
  laser       simulated scans per second (1081 beams) on the built-in world and on
              willow-full, one core, the simulator's ray casting alone
  sim_rtf     the simulator's real-time factor with one robot, running as fast as it can
              with every topic subscribed (/clock, /tf, /odom, ground truth, 40 Hz scans)
  slam_carmen the SLAM core offline on the CARMEN Intel and ACES logs
  slam_sim    slam_gmapping (ROS node, course parameters, 30 particles) over the tour of
              the built-in world: ATE vs ground truth, map precision / recall, CPU per
              simulated second, peak RSS
  amcl        the amcl core: update cost (5000 particles, 61 beams), tracking on the tour,
              global localization from 20 seeded poses, kidnapping (10 runs)
  planning    the path-planning core (no ROS): NavFn plan time on willow-full-0.05 and its
              path against the exact grid geodesic; one DWA control cycle; closed loop
              (global + local costmaps, NavFn, DWA, simulator) over 50 seeded goal pairs on
              the built-in world and 20 on willow-full-0.05: share reached, collisions,
              median of time to goal / (planned path length / max_vel_x)
  explore     frontier exploration (explore.launch, real time) of the built-in world from 5
              seeded start poses and of willow-full from one: explored share of the reachable free area,
              collisions, simulated time, map precision / recall
  patrol      the patrol: 10 rounds over table, room, turtle with a box dropped on the route
              twice: spots reached / skipped, collisions, the boxes kept clear of
  multi_robot the multi-robot lesson (both robots' goals, amcl and fake_localization) and
              the number of robots (amcl + move_base each) run at >= 1x real time
  e2e         (only with --only e2e) the end-to-end rostest once per seed 1..10

    make bench                      all sections
    make bench BENCH_ARGS="--only laser --runs 3"
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import threading
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from roslaunch_session import RoslaunchSession, wait_for  # noqa: E402

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(WS, "output")
DATA = os.path.join(WS, "data")  # real maps and logs (data/README.md)
WORLDS = {
    "built-in course building": os.path.join(WS, "src", "summit_xl_sim", "worlds", "course_building.yaml"),
    "willow-full (0.1 m)": os.path.join(WS, "src", "my_summit_navigation", "maps", "willow-full.yaml"),
    "willow-full-0.05": os.path.join(DATA, "maps", "willow-full-0.05.yaml"),
}


def peak_rss_mb():
    """Peak resident memory of this process so far [MB]."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def bench_laser(runs, scans_per_run=500):
    """Scans per second of World.cast with 1081 beams from random free poses."""
    from summit_xl_sim.sim import LaserParams
    from summit_xl_sim.world import World

    rows = []
    angles = LaserParams().angles()
    for name, path in WORLDS.items():
        if not os.path.exists(path):
            rows.append({"world": name, "skipped": f"{path} missing"})
            continue
        world = World.from_yaml(path)
        rng = np.random.default_rng(0)
        ys, xs = np.nonzero((world.dist * world.resolution > 0.4) & (world.grid.data == 0))
        sel = rng.choice(len(xs), scans_per_run)
        poses = [world.grid.cell_to_world(xs[k], ys[k]) + (rng.uniform(-np.pi, np.pi),) for k in sel]
        world.cast(poses[0][0], poses[0][1], angles, 30.0)  # compile / warm up
        rates = []
        for _ in range(runs):
            t0 = time.process_time()
            for x, y, yaw in poses:
                world.cast(x, y, angles + yaw, 30.0)
            rates.append(scans_per_run / (time.process_time() - t0))
        rows.append({"world": name, "cells": f"{world.grid.width} x {world.grid.height}",
                     "scans_per_s": statistics.median(rates), "runs": [round(r) for r in rates],
                     "peak_rss_mb": peak_rss_mb()})
    return rows


def bench_sim_rtf_once(seconds=20.0):
    """Real-time factor of the simulator node at speed 0 (as fast as it can), one run.

    rospy binds a process to one master, so each run is a child process (see
    bench_sim_rtf_runs) with its own launch.
    """
    import psutil
    import rospy
    from nav_msgs.msg import Odometry
    from rosgraph_msgs.msg import Clock
    from rospy.numpy_msg import numpy_msg
    from sensor_msgs.msg import LaserScan
    from tf2_msgs.msg import TFMessage

    log = os.path.join(OUT, "bench_sim_rtf.log")
    with RoslaunchSession(["summit_xl_sim", "sim.launch", "speed:=0"], log=log) as session:
        rospy.init_node("bench", anonymous=True, disable_signals=True)
        counts = {"scan": 0, "odom": 0, "truth": 0, "tf": 0, "clock": 0}
        latest = {"t": 0.0}
        lock = threading.Lock()

        def counter(key):
            def cb(msg):
                with lock:
                    counts[key] += 1
                    if key == "clock":
                        latest["t"] = msg.clock.to_sec()
            return cb

        rospy.Subscriber("/hokuyo_base/scan", numpy_msg(LaserScan), counter("scan"), queue_size=100)
        rospy.Subscriber("/odom", Odometry, counter("odom"), queue_size=100)
        rospy.Subscriber("/base_pose_ground_truth", Odometry, counter("truth"), queue_size=100)
        rospy.Subscriber("/tf", TFMessage, counter("tf"), queue_size=100)
        rospy.Subscriber("/clock", Clock, counter("clock"), queue_size=100)
        wait_for(lambda: counts["scan"] > 0, 60, "the first scan", session)
        sim = next(p for p in psutil.Process(session.proc.pid).children(recursive=True)
                   if "summit_xl_sim/summit_xl_sim" in " ".join(p.cmdline()))
        cpu0 = sum(sim.cpu_times()[:2])
        with lock:
            t0, c0 = latest["t"], dict(counts)
        w0 = time.monotonic()
        time.sleep(seconds)
        with lock:
            t1, c1 = latest["t"], dict(counts)
        w1 = time.monotonic()
        cpu1 = sum(sim.cpu_times()[:2])
        rss = sim.memory_info().rss / 1e6
    sim_s = max(t1 - t0, 1e-9)
    return {"rtf": sim_s / (w1 - w0), "sim_cpu_s_per_sim_s": (cpu1 - cpu0) / sim_s,
            "scan_hz_sim": (c1["scan"] - c0["scan"]) / sim_s, "odom_hz_sim": (c1["odom"] - c0["odom"]) / sim_s,
            "clock_hz_sim": (c1["clock"] - c0["clock"]) / sim_s, "sim_rss_mb": rss}


def bench_sim_rtf_runs(runs):
    """Runs bench_sim_rtf in `runs` child processes (one ROS master each); medians."""
    rows = []
    for _ in range(runs):
        r = subprocess.run([sys.executable, __file__, "--only", "sim_rtf_child"], stdout=subprocess.PIPE,
                           stderr=subprocess.DEVNULL, text=True, timeout=300)
        line = [l for l in r.stdout.splitlines() if l.startswith("{")]
        if r.returncode != 0 or not line:
            raise RuntimeError(f"simulator benchmark child failed:\n{r.stdout[-2000:]}")
        rows.append(json.loads(line[-1]))
    med = {k: statistics.median(r[k] for r in rows) for k in rows[0]}
    med["runs_rtf"] = [round(r["rtf"], 1) for r in rows]
    return med


def bench_slam_carmen():
    script = os.path.join(WS, "src", "my_summit_mapping", "scripts", "bench_slam_carmen.py")
    if not os.path.exists(script):
        return None
    path = os.path.join(OUT, "bench_slam_carmen.json")
    subprocess.run([sys.executable, script, "--json", path, "--out", OUT], check=True)
    with open(path) as f:
        return json.load(f)


def bench_slam_sim(runs):
    script = os.path.join(WS, "src", "my_summit_mapping", "scripts", "bench_slam_sim.py")
    path = os.path.join(OUT, "bench_slam_sim.json")
    subprocess.run([sys.executable, script, "--runs", str(runs), "--speed", "3", "--json", path, "--out", OUT],
                   check=True)
    with open(path) as f:
        return json.load(f)


def bench_amcl():
    script = os.path.join(WS, "src", "my_summit_localization", "scripts", "bench_amcl_core.py")
    path = os.path.join(OUT, "bench_amcl.json")
    subprocess.run([sys.executable, script, "--json", path], check=True)
    with open(path) as f:
        return json.load(f)


def bench_planning(runs):
    """The path-planning core benchmark; timings are medians over `runs` repeats (the
    closed loop is seeded and deterministic, so it runs once)."""
    script = os.path.join(WS, "src", "my_summit_path_planning", "scripts", "bench_planning_core.py")
    path = os.path.join(OUT, "bench_planning.json")
    subprocess.run([sys.executable, script, "--repeats", str(runs), "--runs", "50", "--willow-runs", "20",
                    "--json", path], check=True)
    with open(path) as f:
        res = json.load(f)
    # For contrast, the built-in world's closed loop at the base's top speed (1.5 m/s):
    # the in-place turns and the acceleration take the same time at any max_vel_x, so
    # they weigh more in the time ratio the faster the robot may drive.
    fast_path = os.path.join(OUT, "bench_planning_fast.json")
    subprocess.run([sys.executable, script, "--skip-navfn", "--runs", "50", "--max-vel-x", "1.5",
                    "--json", fast_path], check=True)
    with open(fast_path) as f:
        fast = json.load(f)
    res["closed_loop_builtin_fast"] = dict(fast["closed_loop_builtin"], max_vel_x=fast["max_vel_x"])
    for key in ("closed_loop_builtin", "closed_loop_willow", "closed_loop_builtin_fast"):
        if key in res:  # the per-run details stay in the JSON files
            res[key] = {k: v for k, v in res[key].items() if k != "runs_detail"}
    return res


def _json_tail(out):
    """The JSON document at the end of a script's output."""
    start = out.rfind("\n{")
    return json.loads(out[start + 1:] if start >= 0 else out)


def bench_explore():
    """bench_explore.py on the built-in world (5 seeded starts) and willow-full (1), at
    real time: slam_gmapping, move_base on the growing map and explore together need
    about 1.5 cores, so faster than real time starves them on 2 cores."""
    script = os.path.join(WS, "src", "my_summit_navigation", "scripts", "bench_explore.py")
    res = {}
    for world, runs in (("builtin", 5), ("willow", 1)):
        path = os.path.join(OUT, f"bench_explore_{world}.json")
        subprocess.run([sys.executable, script, "--world", world, "--runs", str(runs), "--speed", "1",
                        "--json", path], check=True)
        with open(path) as f:
            res[world] = json.load(f)
    return res


def bench_patrol():
    """bench_patrol.py: 10 rounds over the three spots, a box on the route twice."""
    script = os.path.join(WS, "src", "my_summit_navigation", "scripts", "bench_patrol.py")
    path = os.path.join(OUT, "bench_patrol.json")
    subprocess.run([sys.executable, script, "--rounds", "10", "--speed", "1", "--json", path])
    with open(path) as f:
        return json.load(f)


def bench_multi_robot(runs):
    script = os.path.join(WS, "src", "my_summit_navigation", "scripts", "bench_multi_robot.py")
    out = subprocess.run([sys.executable, script, "--runs", str(runs), "--window", "30"], check=True,
                         stdout=subprocess.PIPE, text=True).stdout
    return _json_tail(out)


def bench_e2e():
    out = subprocess.run([sys.executable, os.path.join(WS, "tools", "e2e_seeds.py")] + [str(s) for s in range(1, 11)],
                         stdout=subprocess.PIPE, text=True).stdout
    print(out)
    last = out.strip().splitlines()[-1]
    return {"passed": int(last.split()[0]), "failed": int(last.split()[2]), "lines": out.strip().splitlines()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", action="append", help="laser, sim_rtf, slam_carmen, slam_sim, amcl, planning, explore, "
                    "patrol, multi_robot, e2e (repeatable)")
    ap.add_argument("--runs", type=int, default=5, help="runs per figure (median reported)")
    args = ap.parse_args()
    if args.only == ["sim_rtf_child"]:
        print(json.dumps(bench_sim_rtf_once()))
        return 0
    only = set(args.only or ["laser", "sim_rtf", "slam_carmen", "slam_sim", "amcl", "planning", "explore",
                             "patrol", "multi_robot"])
    os.makedirs(OUT, exist_ok=True)
    report = {"machine": {"cores": os.cpu_count(), "python": sys.version.split()[0]}}
    lines = ["| benchmark | figure | target | peak RSS [MB] |", "| --- | --- | --- | --- |"]
    if "laser" in only:
        report["laser"] = bench_laser(args.runs)
        for r in report["laser"]:
            if "skipped" in r:
                continue
            target = {"built-in course building": ">= 2000", "willow-full (0.1 m)": ">= 1000"}.get(r["world"], "-")
            lines.append(f"| laser scans/s, 1081 beams, {r['world']} ({r['cells']}) | "
                         f"{r['scans_per_s']:.0f} | {target} | {r['peak_rss_mb']:.0f} |")
    if "sim_rtf" in only:
        med = bench_sim_rtf_runs(max(1, min(args.runs, 3)))
        report["sim_rtf"] = med
        lines.append(f"| simulator real-time factor, 1 robot, all topics subscribed | {med['rtf']:.1f}x "
                     f"(runs {med['runs_rtf']}; {med['sim_cpu_s_per_sim_s'] * 1000:.0f} ms CPU per sim s; "
                     f"scan {med['scan_hz_sim']:.1f} Hz, odom {med['odom_hz_sim']:.1f} Hz, clock "
                     f"{med['clock_hz_sim']:.0f} Hz sim) | >= 20x | {med['sim_rss_mb']:.0f} |")
    if "slam_carmen" in only:
        res = bench_slam_carmen()
        if res is not None:
            report["slam_carmen"] = res
            for r in res["results"]:
                lines.append(f"| SLAM core offline, CARMEN {r['log']}, {r['particles']} particles: ATE RMSE "
                             f"SLAM / drifted odometry [m] | {r['ate_slam_m']:.3f} / {r['ate_odom_m']:.3f} "
                             f"({r['cpu_ms_per_processed_scan']:.0f} ms CPU per scan, {r['processed_scans']} scans) | "
                             f"{'<= 0.10' if r['log'] == 'intel' else '-'} | {r['peak_rss_mb']:.0f} |")
    if "slam_sim" in only:
        res = bench_slam_sim(args.runs)
        report["slam_sim"] = res
        m = res["median"]
        worst = {k: (max if k in ("ate_m", "cpu_per_sim_s") else min)(r[k] for r in res["runs"])
                 for k in ("ate_m", "precision", "recall", "cpu_per_sim_s")}
        lines.append(f"| slam_gmapping on the built-in world tour, 30 particles ({len(res['runs'])} runs): "
                     f"ATE RMSE [m] | {m['ate_m']:.3f} (worst {worst['ate_m']:.3f}) | <= 0.05 | {m['peak_rss_mb']:.0f} |")
        lines.append(f"| ... map precision / recall | {m['precision']:.3f} / {m['recall']:.3f} "
                     f"(worst {worst['precision']:.3f} / {worst['recall']:.3f}) | >= 0.95 / >= 0.90 | - |")
        lines.append(f"| ... SLAM CPU s per simulated s | {m['cpu_per_sim_s']:.3f} (worst {worst['cpu_per_sim_s']:.3f}) "
                     f"| <= 0.33 | - |")
    if "amcl" in only:
        res = bench_amcl()
        report["amcl"] = res
        for c in res.get("cost", []):
            lines.append(f"| amcl update, {c['particles']} particles x {c['beams']} beams, {c['map']}: median "
                         f"[ms] | {c['median_ms']:.1f} (with the pose estimate {c['with_estimate_median_ms']:.1f}) "
                         f"| <= 10 | {c['peak_rss_mb']:.0f} |")
        if "tracking" in res:
            t = res["tracking"]
            lines.append(f"| amcl tracking on the tour from the known pose: position / yaw RMSE after 5 s | "
                         f"{t['position_rmse_m']:.3f} m / {t['yaw_rmse_deg']:.2f} deg | <= 0.05 m / <= 2 deg "
                         f"| {t['peak_rss_mb']:.0f} |")
        if "global" in res:
            g = res["global"]
            lines.append(f"| amcl global localization, converged within 15 m of driving | {g['converged']} of "
                         f"{g['runs']} | >= 18 of 20 | {g['peak_rss_mb']:.0f} |")
        if "kidnap" in res:
            k = res["kidnap"]
            lines.append(f"| amcl kidnapping, recovered within 15 m | {k['recovered']} of {k['runs']} | >= 8 of 10 "
                         f"| {k['peak_rss_mb']:.0f} |")
    if "planning" in only:
        res = bench_planning(args.runs)
        report["planning"] = res
        rss = f"{res['peak_rss_mb']:.0f}"
        n = res["navfn_willow"]
        lines.append(f"| NavFn plan on willow-full-0.05 ({n['pairs']} far pairs, median of {len(n['repeats_median_ms'])} "
                     f"repeats): median [ms] | {n['median_ms']:.0f} wall / {n['cpu_median_ms']:.0f} CPU (repeats "
                     f"{n['repeats_median_ms']}) | <= 100 | {rss} |")
        lines.append(f"| ... path / exact grid geodesic: worst (median) | {n['length_ratio_max']:.3f} "
                     f"({n['length_ratio_median']:.3f}) | <= 1.05 | - |")
        d = res["dwa_cycle"]
        lines.append(f"| DWA control cycle, {d['samples']} samples: median [ms] | {d['median_ms']:.2f} wall / "
                     f"{d['cpu_median_ms']:.2f} CPU (repeats {d['repeats_median_ms']}) | <= 10 | - |")
        for key, name, vx in (("closed_loop_builtin", "built-in world", res["max_vel_x"]),
                              ("closed_loop_willow", "willow-full-0.05", res["max_vel_x"]),
                              ("closed_loop_builtin_fast", "built-in world",
                               res.get("closed_loop_builtin_fast", {}).get("max_vel_x"))):
            c = res.get(key)
            if c is None:
                continue
            ratio = "-" if c["ratio_median"] is None else f"{c['ratio_median']:.2f}"
            lines.append(f"| closed loop, {name}, {c['runs']} seeded pairs, max_vel_x {vx} m/s: reached / "
                         f"collisions / median time ratio | {c['reached_share'] * 100:.0f}% / {c['collisions']} / "
                         f"{ratio} | >= 98% / 0 / <= 1.5 | - |")
    if "explore" in only:
        res = bench_explore()
        report["explore"] = res
        for world, r in res.items():
            runs = r["runs"]
            med = {k: statistics.median(x.get(k, 0.0) for x in runs) for k in ("precision", "recall", "sim_s")}
            lines.append(f"| exploration of {world} from {len(runs)} seeded start(s): explored share min / median, "
                         f"collisions, simulated time median [s] | {r['coverage_min']:.3f} / {r['coverage_median']:.3f}, "
                         f"{r['collisions']}, {med['sim_s']:.0f} | >= {0.95 if world == 'builtin' else 0.90} each, 0 "
                         f"| - |")
            lines.append(f"| ... map precision / recall, median | {med['precision']:.3f} / {med['recall']:.3f} | "
                         f">= 0.95 / >= 0.90 | - |")
    if "patrol" in only:
        res = bench_patrol()
        report["patrol"] = res
        boxes = ", ".join(f"{b['min_dist']:.2f}" for b in res["boxes"]) or "none dropped"
        lines.append(f"| patrol, {res['rounds']} rounds x 3 spots, a box on the route twice: reached / skipped, "
                     f"collisions, robot centre to box [m] | {res['reached']} / {res['skipped']}, "
                     f"{res['collisions']}, {boxes} | every spot reached or skipped, 0, > "
                     f"{res['box_clearance_needed_m']:.2f} | - |")
    if "multi_robot" in only:
        res = bench_multi_robot(min(args.runs, 3))
        report["multi_robot"] = res
        for loc, r in res.get("lesson", {}).items():
            lines.append(f"| multi-robot lesson ({loc}): runs passed, goals reached, collisions, median / max "
                         f"xy error [m] | {r['runs_passed']}/{r['runs']}, {r['goals_reached']}/{r['goals']}, "
                         f"{r['collisions']}, {r['median_xy_error_m']} / {r['max_xy_error_m']} | all, 0 | - |")
        sc = res.get("scale")
        if sc:
            per = [row.get("cpu_cores_per_robot_median") for row in sc["rows"] if row.get("rtf", 0) >= sc["rtf_threshold"]]
            lines.append(f"| robots (amcl + move_base each) at >= 1x real time on willow-full; cores per robot | "
                         f"{sc['max_robots_at_real_time']}; {per[-1] if per else '-'} | report | - |")
    if "e2e" in only:
        res = bench_e2e()
        report["e2e"] = res
        lines.append(f"| end-to-end rostest (course project), seeds 1..10 | {res['passed']} of "
                     f"{res['passed'] + res['failed']} | 10 of 10 | - |")
    path = os.path.join(OUT, "bench.json")
    with open(path + ".tmp", "w") as f:
        json.dump(report, f, indent=2)
    os.replace(path + ".tmp", path)
    print("\n".join(lines))
    print(f"\nJSON: {os.path.relpath(path, WS)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
