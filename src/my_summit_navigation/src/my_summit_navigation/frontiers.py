"""Frontier search for exploration, in the manner of explore_lite (no ROS here).

Reference: B. Yamauchi, "A frontier-based approach for autonomous exploration", CIRA
1997; explore_lite (J. Horner, m-explore, ROS wiki) for the costs and parameters:
potential_scale, gain_scale, orientation_scale, min_frontier_size, progress_timeout.

On a costmap_2d-style grid (nav_msgs/OccupancyGrid values of move_base's global costmap:
-1 unknown, 0 free, 1..98 inflated, 99 inscribed, 100 lethal):

1. reachable: the cells the robot centre can reach, the 4-connected component of cells
   below the inscribed cost that holds the robot (scipy.ndimage.label);
2. frontier cells: unknown cells with a reachable 4-neighbour;
3. frontiers: 8-connected groups of frontier cells (cv2.connectedComponentsWithStats),
   at least min_frontier_size [m] long (cell count x resolution);
4. for each, its goal: start from the reachable cell next to the frontier nearest to the
   frontier's centroid (explore_lite's goal), then step back from the edge to the nearest
   reachable cell at least goal_margin from every unreachable one (unknown, wall, its
   inflation), in sight of that cell and within goal_search of it. A goal on the very edge
   of the known space turns into an obstacle as soon as the next map shows the wall
   behind the frontier, and move_base aborts it; explore_lite leaves that to the global
   planner's tolerance. Its distance: the travel distance from the robot over reachable
   cells (Dijkstra over the reachable cells, scipy.sparse.csgraph);
5. cost = potential_scale * distance - gain_scale * size [m]; cheapest first. Goals near
   a blacklisted point (failed before) are left out.
"""
import math
from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

UNKNOWN, INSCRIBED = -1, 99   # OccupancyGrid values of costmap_2d's NO_INFORMATION / INSCRIBED
KERNEL4 = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], np.uint8)   # a cell and its 4 neighbours


@dataclass
class Frontier:
    """A frontier: size [m], centroid and goal (x, y) [m] in the grid's frame, travel
    distance [m] from the robot, cost (lower is better)."""

    size: float
    centroid: tuple
    goal: tuple
    distance: float
    cost: float = 0.0


@dataclass
class FrontierParams:
    """explore_lite's parameters (same names and meanings)."""

    potential_scale: float = 3.0
    gain_scale: float = 1.0
    min_frontier_size: float = 0.75   # [m]
    blacklist_radius: float = 0.5     # [m] goals this close to a failed one are left out
    goal_margin: float = 0.3          # [m] ours: goal this far from unreachable cells ...
    goal_search: float = 1.0          # [m] ... if there is such a cell this close to the edge


def passable_mask(grid):
    """Known cells the robot centre may stand on: cost below the inscribed cost."""
    return (grid >= 0) & (grid < INSCRIBED)


def robot_cell(robot_xy, origin, resolution):
    """(row, col) of the cell holding robot_xy (x, y) [m]; origin: cell (0, 0)'s corner."""
    return int((robot_xy[1] - origin[1]) / resolution), int((robot_xy[0] - origin[0]) / resolution)


def reachable_mask(grid, start_cell):
    """(mask, start): the cells the robot centre reaches from start_cell (row, col), the
    4-connected component of known cells below the inscribed cost, and the cell it was
    grown from. When start_cell is blocked or unknown (the robot close to a wall) the
    nearest passable cell within 10 cells is used; none: an empty mask."""
    passable = passable_mask(grid)
    r, c = start_cell
    if not (0 <= r < grid.shape[0] and 0 <= c < grid.shape[1]):
        return np.zeros_like(passable), (r, c)
    if not passable[r, c]:
        # The robot may stand in its own inscribed zone (close to a wall): start from the
        # nearest passable cell around it.
        r0, r1, c0, c1 = max(0, r - 10), min(grid.shape[0], r + 11), max(0, c - 10), min(grid.shape[1], c + 11)
        rr, cc = np.nonzero(passable[r0:r1, c0:c1])
        if len(rr) == 0:
            return np.zeros_like(passable), (r, c)
        k = np.argmin((rr + r0 - r) ** 2 + (cc + c0 - c) ** 2)
        r, c = rr[k] + r0, cc[k] + c0
    labels, _ = ndimage.label(passable)
    return labels == labels[r, c], (int(r), int(c))


def travel_distances(reach, start_cell, resolution):
    """Travel distance [m] from start_cell to every cell of reach (np.inf elsewhere): Dijkstra
    over the reachable cells, 8-connected (scipy.sparse.csgraph). Only reachable cells are
    graph nodes, so even a one-cell wall separates its sides."""
    h, w = reach.shape
    idx = -np.ones((h, w), np.int64)
    nodes = np.flatnonzero(reach)
    idx.flat[nodes] = np.arange(len(nodes))
    rows, cols, wts = [], [], []
    for dr, dc, d in ((0, 1, 1.0), (1, 0, 1.0), (1, 1, math.sqrt(2)), (1, -1, math.sqrt(2))):
        # pairs (r, c) -> (r + dr, c + dc) with both inside the grid
        ca0, ca1 = (0, w - dc) if dc >= 0 else (-dc, w)
        a = idx[0:h - dr, ca0:ca1]
        b = idx[dr:h, ca0 + dc:ca1 + dc]
        ok = (a >= 0) & (b >= 0)
        rows.append(a[ok])
        cols.append(b[ok])
        wts.append(np.full(int(ok.sum()), d))
    n = len(nodes)
    out = np.full((h, w), np.inf)
    src = idx[start_cell[0], start_cell[1]] if 0 <= start_cell[0] < h and 0 <= start_cell[1] < w else -1
    if src < 0:
        return out
    graph = coo_matrix((np.concatenate(wts), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)).tocsr()
    out.flat[nodes] = dijkstra(graph, directed=False, indices=int(src)) * resolution
    return out


def margin_goal(reach, margin, anchor, resolution, params):
    """The goal cell (row, col) for a frontier whose nearest edge cell is anchor: the
    reachable cell closest to anchor with margin >= goal_margin (margin: distance [m] of
    each cell to the nearest unreachable one), within goal_search of anchor, and whose
    straight line to anchor runs over reachable cells only (so the frontier stays in
    sight). No such cell: the one with the largest margin; anchor if nothing is better."""
    r0, c0 = anchor
    k = int(math.ceil(params.goal_search / resolution))
    h, w = reach.shape
    ra, rb, ca, cb = max(0, r0 - k), min(h, r0 + k + 1), max(0, c0 - k), min(w, c0 + k + 1)
    rr, cc = np.nonzero(reach[ra:rb, ca:cb])
    rr, cc = rr + ra, cc + ca
    d = np.hypot(rr - r0, cc - c0)
    keep = d <= k
    rr, cc, d = rr[keep], cc[keep], d[keep]
    # line of sight: sample each segment candidate -> anchor every half cell
    n = max(2, 2 * k + 1)
    t = np.linspace(0.0, 1.0, n)[None, :]
    sr = np.rint(rr[:, None] + (r0 - rr[:, None]) * t).astype(np.int64)
    sc = np.rint(cc[:, None] + (c0 - cc[:, None]) * t).astype(np.int64)
    seen = reach[sr, sc].all(axis=1)
    rr, cc, d = rr[seen], cc[seen], d[seen]
    m = margin[rr, cc]
    ok = m >= params.goal_margin - 1e-9
    if ok.any():
        j = np.flatnonzero(ok)[np.argmin(d[ok])]
    else:
        # the widest spot: largest margin (to the cell), then the nearest
        j = np.lexsort((d, -np.round(m / resolution)))[0]
    return int(rr[j]), int(cc[j])


def find_frontiers(grid, resolution, origin, robot_xy, params=FrontierParams(), blacklist=()):
    """Frontiers of grid (int array, row 0 = lowest y) seen from robot_xy, cheapest first.

    origin: (x, y) [m] of cell (0, 0)'s corner. Returns [Frontier]."""
    grid = np.asarray(grid)
    ox, oy = origin
    reach, rc = reachable_mask(grid, robot_cell(robot_xy, origin, resolution))
    if not reach.any():
        return []
    unknown = grid == UNKNOWN
    near_reach = cv2.dilate(reach.astype(np.uint8), KERNEL4).astype(bool)
    frontier = unknown & near_reach
    if not frontier.any():
        return []
    n, labels, stats, centroids = cv2.connectedComponentsWithStats(frontier.astype(np.uint8), connectivity=8)
    # the reachable cells next to each frontier (where the robot can stand to see it)
    edge = reach & cv2.dilate(frontier.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    edge_lab = cv2.dilate(labels.astype(np.float32), np.ones((3, 3), np.uint8)).astype(np.int64)
    er, ec = np.nonzero(edge)
    dist = travel_distances(reach, rc, resolution)
    # distance [m] of each reachable cell to the nearest unreachable one (cv2 measures to
    # the nearest zero pixel, centre to centre)
    margin = cv2.distanceTransform(reach.astype(np.uint8), cv2.DIST_L2, 5) * resolution
    out = []
    for k in range(1, n):
        size = stats[k, cv2.CC_STAT_AREA] * resolution
        if size < params.min_frontier_size:
            continue
        cx, cy = centroids[k]   # (col, row)
        mine = edge_lab[er, ec] == k
        if not mine.any():
            continue
        r, c = er[mine], ec[mine]
        j = np.argmin((c - cx) ** 2 + (r - cy) ** 2)
        gr, gc = margin_goal(reach, margin, (r[j], c[j]), resolution, params)
        goal = (ox + (gc + 0.5) * resolution, oy + (gr + 0.5) * resolution)
        if any(math.hypot(goal[0] - bx, goal[1] - by) < params.blacklist_radius for bx, by in blacklist):
            continue
        d = float(dist[gr, gc])
        if not math.isfinite(d):
            continue
        centroid = (ox + (cx + 0.5) * resolution, oy + (cy + 0.5) * resolution)
        out.append(Frontier(size, centroid, goal, d, params.potential_scale * d - params.gain_scale * size))
    out.sort(key=lambda f: f.cost)
    return out


# [rad] half the angle round the robot's heading that the laser sees with some room to
# spare: the Hokuyo's 270 deg field of view is +-135 deg; a frontier within +-110 deg of the
# heading is in view. Behind the robot (the 90 deg it does not see) it is not.
VIEW_HALF_ANGLE = math.radians(110.0)


def frontiers_out_of_reach(grid, resolution, origin, robot_xy, params=FrontierParams()):
    """How many frontiers (groups of at least min_frontier_size) border known passable
    cells the robot cannot reach: space seen through a gap narrower than the robot, or
    round furniture. find_frontiers leaves them out; explore names them when it stops."""
    grid = np.asarray(grid)
    reach, _ = reachable_mask(grid, robot_cell(robot_xy, origin, resolution))
    near_other = cv2.dilate((passable_mask(grid) & ~reach).astype(np.uint8), KERNEL4).astype(bool)
    near_reach = cv2.dilate(reach.astype(np.uint8), KERNEL4).astype(bool)
    frontier = (grid == UNKNOWN) & near_other & ~near_reach
    n, _, stats, _ = cv2.connectedComponentsWithStats(frontier.astype(np.uint8), connectivity=8)
    return int(np.count_nonzero(stats[1:, cv2.CC_STAT_AREA] * resolution >= params.min_frontier_size))


def in_view(pose, point, half_angle=VIEW_HALF_ANGLE):
    """True when point (x, y) lies within half_angle of the heading of pose (x, y, yaw):
    the laser, looking forward, sees it. A point on the robot counts as in view."""
    dx, dy = point[0] - pose[0], point[1] - pose[1]
    if math.hypot(dx, dy) < 1e-6:
        return True
    return abs(math.remainder(math.atan2(dy, dx) - pose[2], 2 * math.pi)) <= half_angle


def goal_heading(robot_xy, goal, centroid, half_angle=VIEW_HALF_ANGLE):
    """The yaw of a frontier goal: the way the robot drives there (no turn on the spot
    beside a wall at the end), unless the frontier's centroid would then lie outside the
    laser's view from the goal; then facing the centroid. A goal next to the robot
    (the frontier behind it at the start: the laser does not see its rear 90 deg) is where
    this matters: arriving heading the way it happened to move, it would never look."""
    travel = math.atan2(goal[1] - robot_xy[1], goal[0] - robot_xy[0])
    if in_view((goal[0], goal[1], travel), centroid, half_angle):
        return travel
    return math.atan2(centroid[1] - goal[1], centroid[0] - goal[0])


class StuckWatch:
    """Tells a stuck robot from unreachable frontiers (explore_lite cannot: it blacklists
    every goal the robot makes no progress towards). `goals` goals in a row given up while
    the robot never left a circle of `distance` [m] round where it was when the first of
    them was given up: the goals were not the problem, the robot cannot move (on
    willow-full a robot wedged beside furniture had 11 reachable frontiers blacklisted one
    by one, 34 s apart, and the run ended with "no reachable frontier left"). Not too
    few: in another run a robot wedged for 3 minutes, 3 goals given up, got free and
    explored on."""

    def __init__(self, goals=6, distance=0.5):
        self.goals = int(goals)
        self.distance = float(distance)
        self.where = []   # robot (x, y) at each give-up since it last moved away

    def update(self, robot_xy):
        """The robot's position now (call it every round): out of the circle, start over."""
        if self.where and math.hypot(robot_xy[0] - self.where[0][0],
                                     robot_xy[1] - self.where[0][1]) > self.distance:
            self.where = []

    def given_up(self, robot_xy):
        """A goal given up with the robot at robot_xy; True when the robot is stuck."""
        self.update(robot_xy)
        self.where.append(tuple(robot_xy))
        return self.goals > 0 and len(self.where) >= self.goals


class GoalProgress:
    """Progress towards the active goal, remembered across goal switches.

    explore_lite restarts its progress timer with every goal it sends. When a choke
    point flickers between passable and inscribed as the map updates, the cheapest
    frontier flips between a goal through the choke and one far round it, every planning
    round: each send restarted the timer, so neither goal was ever given up, and on
    willow-full the robot dithered for about 300 s. Here a goal within `same` [m] of one
    that was active less than `timeout` [s] ago keeps that goal's best distance and its
    clock; any other goal starts afresh. The clock runs only while its goal is active
    (time spent driving to another goal is no failure of this one): a goal is given up
    after `timeout` of being active without progress, `min_progress` [m] closer than the
    best so far (patrol_logic.ProgressWatch's rule)."""

    def __init__(self, timeout=30.0, same=0.5, min_progress=0.1):
        self.timeout = float(timeout)
        self.same = float(same)
        self.min_progress = float(min_progress)
        # [goal (x, y), best distance, time of progress (shifted by the time the goal was
        # inactive), time last active]
        self.goals = []
        self.active = None

    def start(self, goal, now):
        """The goal is sent at time now; True when it continues an earlier goal's watch."""
        if self.active is not None:
            self.active[3] = now           # the goal active till now
        self.goals = [g for g in self.goals if now - g[3] <= self.timeout]
        for g in self.goals:
            if math.hypot(goal[0] - g[0][0], goal[1] - g[0][1]) <= self.same:
                if g is not self.active:
                    g[2] += now - g[3]     # its clock stood still while it was inactive
                self.active = g
                return True
        self.active = [tuple(goal), math.inf, now, now]
        self.goals.append(self.active)
        return False

    def forget(self, goal):
        """Drop the watch of goals within same of goal: sent again later, it starts afresh."""
        self.goals = [g for g in self.goals if math.hypot(goal[0] - g[0][0], goal[1] - g[0][1]) > self.same]
        if self.active is not None and self.active not in self.goals:
            self.active = None

    def stalled(self, now):
        """[s] the active goal has been active without progress (0 when none is active)."""
        return 0.0 if self.active is None or self.active[1] == math.inf else max(0.0, now - self.active[2])

    def update(self, distance, now):
        """The robot's distance to the active goal at time now; True once no progress
        for timeout."""
        g = self.active
        g[3] = now
        if distance < g[1] - self.min_progress or g[1] == math.inf:
            g[1], g[2] = distance, now
            return False
        return self.timeout > 0 and now - g[2] > self.timeout


class Blacklist:
    """Goals explore sends no more, with one more try for those given up for no progress.

    explore_lite's blacklist is permanent. A goal move_base aborts (no path, or its
    recoveries ran out) is given up for good; so is one reached (its frontier was looked
    at). But a goal given up because the robot made no progress for progress_timeout may
    only have met a local planner stall in furniture: on willow-full (seed 1) the one
    frontier into the west wing's hall was given up so, 6 m away, exploration ended with
    "no reachable frontier left" at 90.0%, and in the final map a path there was open.
    So once no frontier is left, each such goal is released once (second_chance) and may
    be sent again; given up a second time, it stays."""

    def __init__(self, radius=0.5):
        self.radius = float(radius)
        self.points = []     # (x, y) of every goal not to send (find_frontiers' blacklist)
        self.waiting = []    # given up for no progress, not yet released
        self.released = []   # released once: no further chance

    def __iter__(self):
        return iter(self.points)

    def _near(self, goal, points):
        return any(math.hypot(goal[0] - x, goal[1] - y) < self.radius for x, y in points)

    def add(self, goal, no_progress=False):
        """Blacklist goal (x, y); no_progress: given up for no progress, so it gets one more
        try unless it (or a goal within radius of it) already had one."""
        goal = (float(goal[0]), float(goal[1]))
        self.points.append(goal)
        if no_progress and not self._near(goal, self.released):
            self.waiting.append(goal)

    def second_chance(self):
        """Release the goals waiting for one more try; returns them (empty when none)."""
        out, self.waiting = self.waiting, []
        self.released.extend(out)
        self.points = [p for p in self.points if p not in out]
        return out


def explored_share(known, reachable_free):
    """Share of the reachable free cells (bool mask) that are known (bool mask, same
    grid), a known cell counting for its 8 neighbours too (one cell of registration)."""
    total = int(reachable_free.sum())
    if total == 0:
        return 0.0
    near_known = cv2.dilate(known.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    return float((near_known & reachable_free).sum()) / total


def exploration_coverage(world, world_res, world_origin, spawn, slam, slam_res, slam_origin, robot_radius=0.0):
    """Share of the world's reachable free area that the SLAM map knows (free or occupied).

    world: OccupancyGrid values of the true map (0 free, 100 occupied, -1 outside), row 0
    = lowest y, cell (0, 0)'s corner at world_origin (x, y); spawn: (x, y, yaw) where the
    robot started, i.e. the SLAM map frame's pose in the world; slam: the SLAM map's values
    with slam_res and slam_origin (x, y) in its own frame. The reachable free area is the
    4-connected free component holding the spawn point; with robot_radius [m] > 0, the
    free cells within robot_radius of where a disc of that radius can go from the spawn
    point (space seen through a gap narrower than the robot does not count)."""
    world = np.asarray(world)
    free = world == 0
    centre_ok = free
    if robot_radius > 0.0:
        centre_ok = ndimage.distance_transform_edt(free) * world_res > robot_radius
    labels, _ = ndimage.label(centre_ok)
    sr = int((spawn[1] - world_origin[1]) / world_res)
    sc = int((spawn[0] - world_origin[0]) / world_res)
    if labels[sr, sc] == 0:
        raise ValueError(f"the spawn point ({spawn[0]:.2f}, {spawn[1]:.2f}) is not in free space"
                         + (f" {robot_radius:.2f} m from any obstacle" if robot_radius > 0.0 else ""))
    reach = labels == labels[sr, sc]
    if robot_radius > 0.0:
        reach = (ndimage.distance_transform_edt(~reach) * world_res <= robot_radius) & free
    rr, cc = np.nonzero(reach)
    wx = world_origin[0] + (cc + 0.5) * world_res - spawn[0]
    wy = world_origin[1] + (rr + 0.5) * world_res - spawn[1]
    c, s = math.cos(-spawn[2]), math.sin(-spawn[2])
    mx, my = c * wx - s * wy, s * wx + c * wy
    mc = np.floor((mx - slam_origin[0]) / slam_res).astype(np.int64)
    mr = np.floor((my - slam_origin[1]) / slam_res).astype(np.int64)
    slam = np.asarray(slam)
    inside = (mr >= 0) & (mc >= 0) & (mr < slam.shape[0]) & (mc < slam.shape[1])
    known_map = cv2.dilate((slam >= 0).astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    seen = np.zeros(len(rr), bool)
    seen[inside] = known_map[mr[inside], mc[inside]]
    return float(seen.mean())
