"""Copy-on-write patched occupancy grid (gmapping's ScanMatcherMap, in numpy).

Reference: Grisetti, Stachniss, Burgard 2007, "Improved Techniques for Grid Mapping with
Rao-Blackwellized Particle Filters", IEEE T-RO 23(1); GMapping's HierarchicalArray2D
(grid/harray2d.h: patches allocated on demand, shared between particles through
reference-counted pointers) and PointAccumulator (grid/map.h: a cell's occupancy is
hits / visits, the "frequency" model). Ray tracing as in ScanMatcher::registerScan:
every beam is traced on its own with a Bresenham line (GridLineTraversal) from the
laser's cell to the end cell; each cell before the end gets one visit, the end cell of a
beam that returned gets one hit and one visit.

Counting per beam matters. With every cell counted at most once per scan (as this module
did before), a free cell just in front of a wall that one noisy beam ends in scores
1 hit / 1 visit for that scan although dozens of beams crossed it; near a wall face on a
cell boundary (every wall of the simulator's grid world) laser noise does that all the
time, the cells in front of the walls turned "occupied" (> FULLNESS_THRESHOLD) and the
scan matcher's occupied bands grew by a cell towards where the robot happened to look
from. Counted per beam, such a cell keeps a low frequency (1 / 30) and stays free.

Memory: the world is cut into PATCH_CELLS x PATCH_CELLS patches, allocated only where a
beam passed. A patch is one float32 array (2, P, P): hits, visits = 32 KiB at 64 x 64
(float32: a cell near the laser is crossed by up to every beam of every scan).
`copy()` shares every patch; a patch is duplicated the first time one of the sharers
writes to it (copy-on-write), so 100 particles whose lineages merged cost little more
than one map.

Ray tracing is vectorized over all beams of a scan (all Bresenham cells at once, counted
with np.bincount into a scan-sized window), then the window is added into the patches it
touches. `trace_scan_reference` is the slow, obvious per-beam version kept as the test
oracle.

Cell (i, j) covers world x in [i*res, (i+1)*res), y in [j*res, (j+1)*res): the grid's
origin is the world origin, indices may be negative. Arrays are indexed [row=y, col=x].
"""
import math
from fractions import Fraction
from typing import Dict, Optional, Set, Tuple

import numpy as np

PATCH_SHIFT = 6                  # log2 of the patch side [cells]
PATCH_CELLS = 1 << PATCH_SHIFT   # patch side, 64 cells = 3.2 m at 0.05 m [cells]
HITS, VISITS = range(2)          # layers of a patch / a traced window
LAYERS = 2                       # hits, visits [-]
COUNT_LIMIT = 1 << 22            # float32 counts stay exact; both layers halved (keeps the
                                 # frequency) before a cell's visits pass this [-]
FULLNESS_THRESHOLD = 0.1         # gmapping's m_fullnessThreshold: occupied for matching if hits/visits > this [-]
PATCH_BYTES = LAYERS * 4 * PATCH_CELLS * PATCH_CELLS  # float32 layers [bytes]
UNKNOWN = -1                     # OccupancyGrid value of a never-seen cell
OCCUPIED = 100                   # OccupancyGrid value of an occupied cell
FREE = 0                         # OccupancyGrid value of a free cell

Key = Tuple[int, int]


class PatchGrid:
    """Occupancy grid made of on-demand (hits, visits) patches, shared copy-on-write.

    resolution: cell side [m]. Use `copy()` to give another particle the same map.
    """

    def __init__(self, resolution: float):
        if not resolution > 0.0:
            raise ValueError(f"grid resolution must be > 0 m, got {resolution!r}")
        self.resolution = float(resolution)
        self._patches: Dict[Key, np.ndarray] = {}  # (py, px) -> (LAYERS, P, P) float32
        self._owned: Set[Key] = set()              # patches only this grid references

    # ----------------------------------------------------------------- sharing
    def copy(self) -> "PatchGrid":
        """A grid equal to this one sharing all patches (nothing is copied until written)."""
        other = PatchGrid.__new__(PatchGrid)
        other.resolution = self.resolution
        other._patches = dict(self._patches)
        other._owned = set()
        self._owned = set()  # from now on both grids see the patches as shared
        return other

    def patch_count(self) -> int:
        """Number of allocated patches this grid references."""
        return len(self._patches)

    def owned_patch_count(self) -> int:
        """Number of patches this grid may write without copying."""
        return len(self._owned)

    def patch_ids(self) -> Set[int]:
        """Identities of the patch arrays referenced (to count shared memory once)."""
        return {id(p) for p in self._patches.values()}

    def shares_patch_with(self, other: "PatchGrid", key: Key) -> bool:
        """True when both grids reference the very same patch memory at `key`."""
        return key in self._patches and self._patches.get(key) is other._patches.get(key)

    def _writable_patch(self, key: Key) -> np.ndarray:
        patch = self._patches.get(key)
        if patch is None:
            patch = np.zeros((LAYERS, PATCH_CELLS, PATCH_CELLS), np.float32)
        elif key not in self._owned:
            patch = patch.copy()
        else:
            return patch
        self._patches[key] = patch
        self._owned.add(key)
        return patch

    # ------------------------------------------------------------ coordinates
    def world_to_cell(self, xy: np.ndarray) -> np.ndarray:
        """Integer cell indices (..., 2) [col, row] of world points (..., 2) [m]."""
        return np.floor(np.asarray(xy, float) / self.resolution).astype(np.int64)

    def bounds(self) -> Optional[Tuple[int, int, int, int]]:
        """Allocated extent (ix0, iy0, ix1, iy1) in cells, half-open; None if empty."""
        if not self._patches:
            return None
        keys = np.array(list(self._patches.keys()))
        return (int(keys[:, 1].min()) << PATCH_SHIFT, int(keys[:, 0].min()) << PATCH_SHIFT,
                (int(keys[:, 1].max()) + 1) << PATCH_SHIFT, (int(keys[:, 0].max()) + 1) << PATCH_SHIFT)

    # ---------------------------------------------------------------- windows
    def read_window(self, ix0: int, iy0: int, width: int, height: int) -> Tuple[np.ndarray, np.ndarray]:
        """(hits, visits), each (height, width) float32, of the cells from (ix0, iy0).

        Unallocated cells read as 0 visits (unknown). Any window is allowed; it is fastest
        when aligned to patches.
        """
        cells = self.read_layers(ix0, iy0, width, height)
        return cells[HITS], cells[VISITS]

    def read_layers(self, ix0: int, iy0: int, width: int, height: int) -> np.ndarray:
        """Both layers (LAYERS, height, width) float32 (hits, visits) of the cells from (ix0, iy0)."""
        out = np.zeros((LAYERS, height, width), np.float32)
        for key, (wy, wx, py, px, h, w) in _patch_slices(ix0, iy0, width, height):
            patch = self._patches.get(key)
            if patch is not None:
                out[:, wy:wy + h, wx:wx + w] = patch[:, py:py + h, px:px + w]
        return out

    def add_window(self, ix0: int, iy0: int, counts: np.ndarray) -> None:
        """Add per-cell layers (LAYERS, h, w) (as trace_scan makes them) at cell (ix0, iy0).

        Only patches where the visits are non-zero are touched (allocated or copied).
        """
        _, height, width = counts.shape
        for key, (wy, wx, py, px, h, w) in _patch_slices(ix0, iy0, width, height):
            win = counts[:, wy:wy + h, wx:wx + w]
            if not win[VISITS].any():
                continue
            patch = self._writable_patch(key)
            if float(patch[VISITS].max()) + float(win[VISITS].max()) > COUNT_LIMIT:
                # Halve both counters: the frequency hits/visits is what matters.
                patch *= 0.5
            patch[:, py:py + h, px:px + w] += win

    # ------------------------------------------------------------ ray tracing
    def integrate_scan(self, laser_pose: np.ndarray, ranges: np.ndarray, angles: np.ndarray,
                       max_urange: float, max_range: float) -> None:
        """Ray-trace one scan from laser_pose (x [m], y [m], theta [rad]) into the grid.

        ranges (n,) [m], angles (n,) [rad] in the laser frame. A beam with a finite
        range < max_urange and < max_range marks its end cell hit; a beam with no return
        (NaN, inf, >= max_range) or longer than max_urange only frees cells up to
        max_urange; beams with range <= 0 are ignored.
        """
        ix0, iy0, counts = trace_scan(laser_pose, ranges, angles, max_urange, max_range,
                                      self.resolution)
        if counts.size:
            self.add_window(ix0, iy0, counts)

    # ------------------------------------------------------------------ output
    def occupancy_grid(self, occ_thresh: float,
                       extent: Optional[Tuple[float, float, float, float]] = None):
        """ROS OccupancyGrid data of this grid.

        extent: (xmin, ymin, xmax, ymax) [m] the map must at least cover (gmapping's
        initial map size); the map grows to include every allocated patch.
        Returns (data int8 (height*width,) row-major, width, height, resolution [m],
        origin_x [m], origin_y [m]); cells: -1 unknown, 0 free, 100 occupied
        (hits/visits > occ_thresh), as slam_gmapping publishes.
        """
        ix0, iy0, ix1, iy1 = self._output_extent(extent)
        width, height = ix1 - ix0, iy1 - iy0
        data = np.full((height, width), UNKNOWN, np.int8)
        for key, (wy, wx, py, px, h, w) in _patch_slices(ix0, iy0, width, height):
            patch = self._patches.get(key)
            if patch is None:
                continue
            data[wy:wy + h, wx:wx + w] = occupancy_values(patch[HITS, py:py + h, px:px + w],
                                                          patch[VISITS, py:py + h, px:px + w], occ_thresh)
        return (data.reshape(-1), width, height, self.resolution,
                ix0 * self.resolution, iy0 * self.resolution)

    def _output_extent(self, extent):
        boxes = []
        if extent is not None:
            xmin, ymin, xmax, ymax = extent
            boxes.append((int(math.floor(xmin / self.resolution + 1e-9)),
                          int(math.floor(ymin / self.resolution + 1e-9)),
                          int(math.ceil(xmax / self.resolution - 1e-9)),
                          int(math.ceil(ymax / self.resolution - 1e-9))))
        b = self.bounds()
        if b is not None:
            boxes.append(b)
        if not boxes:
            return 0, 0, 1, 1
        arr = np.array(boxes)
        return int(arr[:, 0].min()), int(arr[:, 1].min()), int(arr[:, 2].max()), int(arr[:, 3].max())

    def entropy(self) -> float:
        """Map entropy [nat]: sum over seen cells of the binary entropy of hits/visits."""
        total = 0.0
        for patch in self._patches.values():
            total += float(cell_entropy(patch[HITS], patch[VISITS]).sum())
        return total

    def nbytes(self) -> int:
        """Bytes of patch memory referenced by this grid (shared patches included)."""
        return len(self._patches) * PATCH_BYTES


# ------------------------------------------------------------------ helpers
def _patch_slices(ix0: int, iy0: int, width: int, height: int):
    """Yield (patch key, (win_row, win_col, patch_row, patch_col, h, w)) covering a window."""
    py_first, py_last = iy0 >> PATCH_SHIFT, (iy0 + height - 1) >> PATCH_SHIFT
    px_first, px_last = ix0 >> PATCH_SHIFT, (ix0 + width - 1) >> PATCH_SHIFT
    for py in range(py_first, py_last + 1):
        cy0 = max(iy0, py << PATCH_SHIFT)
        cy1 = min(iy0 + height, (py + 1) << PATCH_SHIFT)
        for px in range(px_first, px_last + 1):
            cx0 = max(ix0, px << PATCH_SHIFT)
            cx1 = min(ix0 + width, (px + 1) << PATCH_SHIFT)
            yield (py, px), (cy0 - iy0, cx0 - ix0, cy0 - (py << PATCH_SHIFT),
                             cx0 - (px << PATCH_SHIFT), cy1 - cy0, cx1 - cx0)


def occupancy_values(hits: np.ndarray, visits: np.ndarray, occ_thresh: float) -> np.ndarray:
    """int8 OccupancyGrid values of cells: -1 unvisited, 100 if hits/visits > occ_thresh, else 0."""
    out = np.where(hits.astype(np.float32) > occ_thresh * visits.astype(np.float32),
                   OCCUPIED, FREE).astype(np.int8)
    out[visits == 0] = UNKNOWN
    return out


def occupied_mask(hits: np.ndarray, visits: np.ndarray,
                  threshold: float = FULLNESS_THRESHOLD) -> np.ndarray:
    """bool mask of cells the scan matcher treats as obstacles (hits/visits > threshold)."""
    return (hits.astype(np.float32) > threshold * visits.astype(np.float32)) & (visits > 0)


def cell_entropy(hits: np.ndarray, visits: np.ndarray) -> np.ndarray:
    """Binary entropy [nat] of each cell's occupancy hits/visits; 0 for unvisited cells."""
    v = visits.astype(np.float64)
    p = np.divide(hits, v, out=np.zeros_like(v), where=v > 0)
    p = np.clip(p, 1e-12, 1.0 - 1e-12)
    h = -(p * np.log(p) + (1.0 - p) * np.log(1.0 - p))
    h[(visits == 0) | (hits == 0) | (hits == visits)] = 0.0
    return h


def beam_endpoints(laser_pose: np.ndarray, ranges: np.ndarray, angles: np.ndarray,
                   max_urange: float, max_range: float):
    """Classify beams and compute ray ends in the world.

    Returns (ends (K, 2) [m] of the used beams, is_hit (K,) bool): hit beams end at the
    measured range, no-return or over-long beams end at max_urange, beams with a range
    <= 0 are dropped.
    """
    r = np.asarray(ranges, float)
    with np.errstate(invalid="ignore"):
        valid = ~(r <= 0.0)                       # NaN stays valid: "no return"
        no_return = ~np.isfinite(r) | (r >= max_range)
    is_hit = valid & ~no_return & (r < max_urange)
    used = valid
    length = np.where(is_hit, r, max_urange)[used]
    a = laser_pose[2] + np.asarray(angles, float)[used]
    ends = np.column_stack((laser_pose[0] + length * np.cos(a), laser_pose[1] + length * np.sin(a)))
    return ends, is_hit[used]


def bresenham_counts(start: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """Number of cells (B,) on the Bresenham lines from cells start (B, 2) to stop (B, 2),
    both ends included: max(|dx|, |dy|) + 1."""
    return np.abs(stop - start).max(axis=1) + 1


def bresenham_cells(start: np.ndarray, stop: np.ndarray):
    """All cells of the Bresenham lines (GridLineTraversal) from integer cells start (B, 2)
    to stop (B, 2), vectorized: (cells (M, 2) int64 in line order, beam index (M,)).

    Along the major axis every cell is taken once; the minor coordinate of step k of n is
    round(k * d / n) (halves rounded up) = floor((2 k d + n) / (2 n)). That is computed
    with a float64 division, which is exact here: numerator and denominator are integers
    far below 2^53 and IEEE division is correctly rounded, so an integer quotient comes out
    exactly and any other stays at least 1 / (2 n) from the next integer (about twice as
    fast as numpy's integer floor division).
    """
    d = stop - start
    n = np.abs(d).max(axis=1)                     # steps per line
    counts = n + 1
    beam = np.repeat(np.arange(len(start)), counts)
    first = np.cumsum(counts) - counts
    k2 = (2 * (np.arange(int(counts.sum())) - np.repeat(first, counts))).astype(np.float64)
    n_rep = np.repeat(np.maximum(n, 1).astype(np.float64), counts)
    cells = np.empty((len(k2), 2), np.int64)
    for axis in range(2):
        minor = np.floor((k2 * np.repeat(d[:, axis], counts) + n_rep) / (2.0 * n_rep))
        cells[:, axis] = np.repeat(start[:, axis], counts) + minor.astype(np.int64)
    return cells, beam


def trace_scan(laser_pose, ranges, angles, max_urange, max_range, resolution):
    """Rasterize a scan into (ix0, iy0, counts (LAYERS, h, w) float32), patch-aligned.

    Per beam (gmapping's registerScan): the Bresenham line from the laser's cell to the end
    cell; every cell but the last gets a visit; the end cell of a returned beam gets a hit
    and a visit. A beam cut at max_urange leaves its last cell untouched, as in gmapping.
    """
    laser_pose = np.asarray(laser_pose, float)
    ends, is_hit = beam_endpoints(laser_pose, ranges, angles, max_urange, max_range)
    if len(ends) == 0:
        return 0, 0, np.zeros((LAYERS, 0, 0), np.float32)
    start_cell = np.floor(laser_pose[:2] / resolution).astype(np.int64)
    end_cells = np.floor(ends / resolution).astype(np.int64)
    lo = np.minimum(end_cells.min(axis=0), start_cell)
    hi = np.maximum(end_cells.max(axis=0), start_cell) + 1
    ix0 = int(lo[0]) >> PATCH_SHIFT << PATCH_SHIFT
    iy0 = int(lo[1]) >> PATCH_SHIFT << PATCH_SHIFT
    width = ((int(hi[0]) - ix0 + PATCH_CELLS - 1) >> PATCH_SHIFT) << PATCH_SHIFT
    height = ((int(hi[1]) - iy0 + PATCH_CELLS - 1) >> PATCH_SHIFT) << PATCH_SHIFT
    cells, _ = bresenham_cells(np.broadcast_to(start_cell, end_cells.shape), end_cells)
    last = np.cumsum(bresenham_counts(np.broadcast_to(start_cell, end_cells.shape), end_cells)) - 1
    passing = np.ones(len(cells), bool)
    passing[last] = False                        # the end cells: hit (returned) or untouched
    flat = (cells[:, 1] - iy0) * width + (cells[:, 0] - ix0)
    size = width * height
    counts = np.zeros((LAYERS, height * width), np.float32)
    counts[VISITS] = np.bincount(flat[passing], minlength=size)
    counts[HITS] = np.bincount(flat[last[is_hit]], minlength=size)
    counts[VISITS] += counts[HITS]
    return ix0, iy0, counts.reshape(LAYERS, height, width)


def trace_scan_reference(laser_pose, ranges, angles, max_urange, max_range, resolution):
    """Slow, obvious per-beam ray tracer (test oracle for `trace_scan`).

    For each beam, a plain Bresenham walk (one cell per step of the major axis, the minor
    coordinate rounded) from the laser's cell to the end cell. Returns a dict
    {(ix, iy): [hits, visits]} as trace_scan's layers.
    """
    laser_pose = np.asarray(laser_pose, float)
    out = {}

    def cell(key):
        return out.setdefault(key, [0.0, 0.0])

    x0 = math.floor(laser_pose[0] / resolution)
    y0 = math.floor(laser_pose[1] / resolution)
    for r, a in zip(ranges, angles):
        r = float(r)
        if r <= 0.0:
            continue
        returned = math.isfinite(r) and r < max_range and r < max_urange
        length = r if returned else max_urange
        th = laser_pose[2] + a
        ex = laser_pose[0] + length * math.cos(th)
        ey = laser_pose[1] + length * math.sin(th)
        x1, y1 = math.floor(ex / resolution), math.floor(ey / resolution)
        n = max(abs(x1 - x0), abs(y1 - y0))
        for k in range(n):
            fx = Fraction(k * (x1 - x0), n) + Fraction(1, 2)
            fy = Fraction(k * (y1 - y0), n) + Fraction(1, 2)
            cell((x0 + math.floor(fx), y0 + math.floor(fy)))[VISITS] += 1
        if returned:
            c = cell((x1, y1))
            c[HITS] += 1
            c[VISITS] += 1
    return out
