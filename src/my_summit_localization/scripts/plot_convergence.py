#!/usr/bin/python3
"""Picture of the particle cloud converging after global localization (no ROS).

The simulator drives the robot with the benchmark's wandering driver from a seeded
random pose; the filter starts from global_localization (particles over all free
space). Three panels: the cloud at the start, after the first few metres, and once
converged; ground truth in green, the estimate in red.

    plot_convergence.py [--out PNG] [--seed N]
"""
import argparse
import math
import os

import cv2
import numpy as np

import bench_amcl_core as bench  # a sibling script: its driver, spawn and filter helpers

HERE = os.path.dirname(os.path.abspath(__file__))

SCALE = 2          # image pixels per map cell
PANEL_AT = (0.0, 0.15)  # driven distance [m] of the first two panels; the third = converged


def draw_panel(world, particles, truth, estimate, title):
    base = np.where(world.grid.data == 100, 0, np.where(world.grid.data == 0, 255, 205)).astype(np.uint8)
    img = cv2.resize(cv2.cvtColor(base[::-1], cv2.COLOR_GRAY2BGR), None, fx=SCALE, fy=SCALE,
                     interpolation=cv2.INTER_NEAREST)
    h = img.shape[0]

    def px(x, y):
        gx, gy = world.to_grid(x, y)
        return int(round(gx * SCALE)), int(round(h - gy * SCALE))

    for x, y, yaw in particles[:: max(1, len(particles) // 3000)]:
        p = px(x, y)
        q = px(x + 0.25 * math.cos(yaw), y + 0.25 * math.sin(yaw))
        cv2.line(img, p, q, (200, 120, 40), 1, cv2.LINE_AA)
    for pose, colour in ((truth, (0, 160, 0)), (estimate, (0, 0, 220))):
        if pose is None:  # no estimate before the first filter update
            continue
        x, y, yaw = pose
        cv2.circle(img, px(x, y), 6, colour, 2, cv2.LINE_AA)
        cv2.line(img, px(x, y), px(x + 0.6 * math.cos(yaw), y + 0.6 * math.sin(yaw)), colour, 2, cv2.LINE_AA)
    cv2.putText(img, title, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (30, 30, 30), 1, cv2.LINE_AA)
    return img


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="particle_cloud_converging.png")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--params", default=os.path.join(HERE, "..", "config", "amcl_params.yaml"))
    args = ap.parse_args()
    cfg = bench.load_params(args.params)
    world = bench.World.from_yaml(bench.BUILTIN)
    rng = np.random.default_rng(args.seed)
    sim = bench.Simulation(world, seed=args.seed)
    sim.add_robot(bench.ROBOT, 2.0, 7.0, 0.0)
    sim.set_pose(bench.ROBOT, *bench.spawn_pose(sim, world, rng))
    state = sim.robots[bench.ROBOT]
    pf = bench.ParticleFilter(cfg, world.grid, np.random.default_rng([args.seed, 1]))
    pf.global_localization()
    panels = [draw_panel(world, pf.particles.copy(), state.pose, pf.pose_at(state.odom_pose),
                         f"global_localization: {pf.n} particles")]
    driver = bench.Wanderer(rng)
    driven = 0.0
    while driven < PANEL_AT[1]:
        _, step, _ = bench.run_until_converged(pf, sim, state, rng, 0.05, stop_when_converged=False, driver=driver)  # noqa
        driven += step
    panels.append(draw_panel(world, pf.particles.copy(), state.pose, pf.pose_at(state.odom_pose),
                             f"after {driven:.1f} m: {pf.n} particles"))
    ok, step, _ = bench.run_until_converged(pf, sim, state, rng, bench.DRIVE_BUDGET, driver=driver)
    driven += step
    est = pf.pose_at(state.odom_pose)
    err = math.hypot(est[0] - state.pose[0], est[1] - state.pose[1])
    panels.append(draw_panel(world, pf.particles.copy(), state.pose, est,
                             f"{'converged' if ok else 'NOT converged'} after {driven:.1f} m: {pf.n} particles, "
                             f"error {err:.2f} m"))
    sep = np.full((panels[0].shape[0], 8, 3), 255, np.uint8)
    out = np.hstack([panels[0], sep, panels[1], sep, panels[2]])
    cv2.imwrite(args.out, out)
    print(f"{args.out}: {'converged' if ok else 'not converged'} after {driven:.1f} m, error {err:.3f} m")


if __name__ == "__main__":
    main()
