"""SLAM run against simulator ground truth: ATE, map precision and recall in the world.

Used by the mapping rostest and by bench_slam_sim.py, so both judge a run the same way.

1. Ground truth at the SLAM trajectory's times: linear interpolation of the recorded
   ground-truth poses (yaw interpolated on the unwrapped angle).
2. ATE: metrics.ate_rmse after the best rigid 2D alignment (Umeyama), which also gives
   the map->world transform (the SLAM map frame is where the robot started).
3. The map in the world: every occupied SLAM cell centre, moved by that transform,
   marks the world cell it falls in (the same 0.05 m grid as the world's walls).
4. Seen walls: from the ground-truth laser pose of every processed scan (the scans that
   made the map), beams are cast in the true world (summit_nav_common.raycast via
   World.cast) up to maxUrange; the wall cell each returning beam ends in is "seen".
5. precision = metrics.map_precision(map_occupied, walls); recall =
   metrics.map_recall(map_occupied, seen_walls): one-cell tolerance both ways.
"""
import math

import numpy as np

from . import metrics

OCCUPIED = 100          # OccupancyGrid value of an occupied cell
HIT_NUDGE_CELLS = 0.5   # move a beam end this far into the wall to find the hit cell [cells]
NO_RETURN_MARGIN = 1e-6  # a cast range within this of the limit counts as no return [m]


def within_span(times, ref_times):
    """bool (K,): which times lie within [min(ref_times), max(ref_times)], where
    interpolate_poses interpolates rather than clamps."""
    t = np.asarray(times, float)
    ref = np.asarray(ref_times, float)
    return (t >= ref.min()) & (t <= ref.max())


def interpolate_poses(times, ref_times, ref_poses):
    """Poses (K, 3) at times (K,) [s] by linear interpolation of ref_poses (M, 3) at
    ascending ref_times (M,); yaw is unwrapped first. Times outside are clamped."""
    ref_times = np.asarray(ref_times, float)
    ref = np.asarray(ref_poses, float)
    yaw = np.unwrap(ref[:, 2])
    out = np.empty((len(times), 3))
    out[:, 0] = np.interp(times, ref_times, ref[:, 0])
    out[:, 1] = np.interp(times, ref_times, ref[:, 1])
    th = np.interp(times, ref_times, yaw)
    out[:, 2] = np.arctan2(np.sin(th), np.cos(th))
    return out


def occupied_in_world(grid, rotation, translation, world):
    """bool (H, W) over the world's grid: cells holding an occupied SLAM cell centre.

    grid: (data int8 (h*w,), w, h, resolution [m], origin_x [m], origin_y [m]) as
    RbpfSlam.occupancy_grid() / an OccupancyGrid gives; rotation (2, 2), translation (2,)
    map the SLAM map frame into the world frame.
    """
    data, width, height, res, ox, oy = grid
    d = np.asarray(data).reshape(height, width)
    rows, cols = np.nonzero(d == OCCUPIED)
    pts = np.column_stack((ox + (cols + 0.5) * res, oy + (rows + 0.5) * res))
    pts = pts @ np.asarray(rotation).T + np.asarray(translation)
    out = np.zeros(world.walls.shape, bool)
    gx, gy = world.to_grid(pts[:, 0], pts[:, 1])
    ix, iy = np.floor(gx).astype(np.int64), np.floor(gy).astype(np.int64)
    ok = (ix >= 0) & (iy >= 0) & (ix < out.shape[1]) & (iy < out.shape[0])
    out[iy[ok], ix[ok]] = True
    return out


def seen_walls(world, laser_poses, angles, max_urange):
    """bool (H, W): wall cells that a beam from one of laser_poses (K, 3) [m, m, rad]
    ends in, beams at angles (n,) [rad] in the laser frame, cast up to max_urange [m]."""
    seen = np.zeros(world.walls.shape, bool)
    angles = np.asarray(angles, float)
    nudge = HIT_NUDGE_CELLS * world.resolution
    for x, y, yaw in laser_poses:
        world_angles = angles + yaw
        r = world.cast(x, y, world_angles, max_urange)
        hit = r < max_urange - NO_RETURN_MARGIN
        reach = r[hit] + nudge
        ex = x + reach * np.cos(world_angles[hit])
        ey = y + reach * np.sin(world_angles[hit])
        gx, gy = world.to_grid(ex, ey)
        ix, iy = np.floor(gx).astype(np.int64), np.floor(gy).astype(np.int64)
        ok = (ix >= 0) & (iy >= 0) & (ix < seen.shape[1]) & (iy < seen.shape[0])
        seen[iy[ok], ix[ok]] = True
    return seen & world.walls


def laser_poses_of(base_poses, mount):
    """World laser poses (K, 3) of base poses (K, 3) with the laser at mount (x, y, yaw)."""
    b = np.asarray(base_poses, float)
    c, s = np.cos(b[:, 2]), np.sin(b[:, 2])
    return np.column_stack((b[:, 0] + c * mount[0] - s * mount[1],
                            b[:, 1] + s * mount[0] + c * mount[1], b[:, 2] + mount[2]))


def evaluate(trajectory, trajectory_times, truth_times, truth_poses, grid, world,
             laser_mount, angles, max_urange):
    """Judge a SLAM run. Returns a dict:
    ate_m (ATE RMSE [m]), precision, recall [0..1], occupied_cells, seen_wall_cells,
    alignment (yaw [rad], tx [m], ty [m]) of the SLAM map frame in the world, and the
    world-sized masks map_occupied / seen_walls (numpy bool) for pictures.

    trajectory (K, 3) at trajectory_times (K,) [s]: the SLAM poses of the processed
    scans; truth_* : ground-truth base poses (M, 3) in the world at truth_times (M,).
    Only the SLAM poses stamped within the truth's time span are scored (scored_poses);
    the truth is not extrapolated. ValueError when none is.
    """
    inside = within_span(trajectory_times, truth_times)
    if not inside.any():
        raise ValueError(f"no SLAM pose lies within the ground truth's time span "
                         f"[{float(np.min(truth_times)):.2f}, {float(np.max(truth_times)):.2f}] s")
    traj = np.asarray(trajectory, float)[inside]
    truth = interpolate_poses(np.asarray(trajectory_times, float)[inside], truth_times, truth_poses)
    rot, t = metrics.rigid_alignment_2d(traj, truth)
    ate = metrics.ate_rmse(traj, truth)
    occ = occupied_in_world(grid, rot, t, world)
    seen = seen_walls(world, laser_poses_of(truth, laser_mount), angles, max_urange)
    return dict(ate_m=ate, scored_poses=int(inside.sum()), precision=metrics.map_precision(occ, world.walls),
                recall=metrics.map_recall(occ, seen), occupied_cells=int(occ.sum()),
                seen_wall_cells=int(seen.sum()),
                alignment=(math.atan2(rot[1, 0], rot[0, 0]), float(t[0]), float(t[1])),
                map_occupied=occ, seen_walls=seen)
