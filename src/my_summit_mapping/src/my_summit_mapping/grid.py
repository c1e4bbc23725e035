"""Copy-on-write patched occupancy grid (gmapping's ScanMatcherMap, in numpy).

Reference: Grisetti, Stachniss, Burgard 2007, "Improved Techniques for Grid Mapping with
Rao-Blackwellized Particle Filters", IEEE T-RO 23(1); GMapping's HierarchicalArray2D
(grid/harray2d.h: patches allocated on demand, shared between particles through
reference-counted pointers) and PointAccumulator (grid/map.h: a cell's occupancy is
hits / visits, the "frequency" model). Ray tracing as in ScanMatcher::registerScan: every
cell a beam crosses is visited, the end cell of a beam that returned is also a hit.

Memory: the world is cut into PATCH_CELLS x PATCH_CELLS patches, allocated only where a
beam passed. A patch is two uint8 arrays (hits, visits) = 8 KiB at 64 x 64. `copy()`
shares every patch; a patch is duplicated the first time one of the sharers writes to it
(copy-on-write), so 100 particles whose lineages merged cost little more than one map.

Ray tracing is done per scan with OpenCV's C line rasterizer (cv2.polylines draws all
beams at once into a scan-sized window), then the window is added into the patches it
touches. A cell counts at most one visit and one hit per scan. `trace_scan_reference` is
the slow, obvious per-beam version kept as the test oracle.

Cell (i, j) covers world x in [i*res, (i+1)*res), y in [j*res, (j+1)*res): the grid's
origin is the world origin, indices may be negative. Arrays are indexed [row=y, col=x].
"""
import math
from typing import Dict, Optional, Set, Tuple

import cv2
import numpy as np

PATCH_SHIFT = 6                  # log2 of the patch side [cells]
PATCH_CELLS = 1 << PATCH_SHIFT   # patch side, 64 cells = 3.2 m at 0.05 m [cells]
COUNT_LIMIT = 255                # uint8 counters; halved (keeps hits/visits) before overflow [-]
LINE_SHIFT = 8                   # fixed-point fractional bits for sub-cell accurate rays [bits]
FULLNESS_THRESHOLD = 0.1         # gmapping's m_fullnessThreshold: occupied for matching if hits/visits > this [-]
PATCH_BYTES = 2 * PATCH_CELLS * PATCH_CELLS  # hits + visits, uint8 each [bytes]
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
        self._patches: Dict[Key, np.ndarray] = {}  # (py, px) -> (2, P, P) uint8 [hits, visits]
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
            patch = np.zeros((2, PATCH_CELLS, PATCH_CELLS), np.uint8)
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
        """(hits, visits), each (height, width) uint8, of the cells from (ix0, iy0).

        Unallocated cells read as 0 visits (unknown). Any window is allowed; it is fastest
        when aligned to patches.
        """
        hits = np.zeros((height, width), np.uint8)
        visits = np.zeros((height, width), np.uint8)
        for key, (wy, wx, py, px, h, w) in _patch_slices(ix0, iy0, width, height):
            patch = self._patches.get(key)
            if patch is not None:
                hits[wy:wy + h, wx:wx + w] = patch[0, py:py + h, px:px + w]
                visits[wy:wy + h, wx:wx + w] = patch[1, py:py + h, px:px + w]
        return hits, visits

    def add_window(self, ix0: int, iy0: int, hits: np.ndarray, visits: np.ndarray) -> None:
        """Add per-cell hit and visit counts (uint8 windows) at cell (ix0, iy0).

        Only patches where `visits` is non-zero are touched (allocated or copied).
        """
        height, width = visits.shape
        for key, (wy, wx, py, px, h, w) in _patch_slices(ix0, iy0, width, height):
            vwin = visits[wy:wy + h, wx:wx + w]
            if not vwin.any():
                continue
            patch = self._writable_patch(key)
            hwin = hits[wy:wy + h, wx:wx + w]
            if int(patch[1].max()) + int(vwin.max()) > COUNT_LIMIT:
                # Halve both counters: the frequency hits/visits is what matters.
                np.right_shift(patch, 1, out=patch)
            patch[0, py:py + h, px:px + w] += hwin
            patch[1, py:py + h, px:px + w] += vwin

    # ------------------------------------------------------------ ray tracing
    def integrate_scan(self, laser_pose: np.ndarray, ranges: np.ndarray, angles: np.ndarray,
                       max_urange: float, max_range: float) -> None:
        """Ray-trace one scan from laser_pose (x [m], y [m], theta [rad]) into the grid.

        ranges (n,) [m], angles (n,) [rad] in the laser frame. A beam with a finite
        range < max_urange and < max_range marks its end cell hit; a beam with no return
        (NaN, inf, >= max_range) or longer than max_urange only frees cells up to
        max_urange; beams with range <= 0 are ignored.
        """
        ix0, iy0, hits, visits = trace_scan(laser_pose, ranges, angles, max_urange, max_range,
                                            self.resolution)
        if visits.size:
            self.add_window(ix0, iy0, hits, visits)

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
            data[wy:wy + h, wx:wx + w] = occupancy_values(patch[0, py:py + h, px:px + w],
                                                          patch[1, py:py + h, px:px + w], occ_thresh)
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
            total += float(cell_entropy(patch[0], patch[1]).sum())
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


def trace_scan(laser_pose, ranges, angles, max_urange, max_range, resolution):
    """Rasterize a scan into (ix0, iy0, hits, visits) uint8 windows, patch-aligned.

    Uses cv2.polylines with LINE_SHIFT fixed-point coordinates (8-connected lines, C
    speed); each crossed cell gets one visit, each returned beam's end cell one hit.
    """
    laser_pose = np.asarray(laser_pose, float)
    ends, is_hit = beam_endpoints(laser_pose, ranges, angles, max_urange, max_range)
    if len(ends) == 0:
        return 0, 0, np.zeros((0, 0), np.uint8), np.zeros((0, 0), np.uint8)
    origin = laser_pose[:2] / resolution                      # [cells, continuous]
    ends_c = ends / resolution
    lo = np.floor(np.minimum(ends_c.min(axis=0), origin)).astype(np.int64) - 1
    hi = np.floor(np.maximum(ends_c.max(axis=0), origin)).astype(np.int64) + 2
    ix0 = int(lo[0]) >> PATCH_SHIFT << PATCH_SHIFT
    iy0 = int(lo[1]) >> PATCH_SHIFT << PATCH_SHIFT
    width = ((int(hi[0]) - ix0 + PATCH_CELLS - 1) >> PATCH_SHIFT) << PATCH_SHIFT
    height = ((int(hi[1]) - iy0 + PATCH_CELLS - 1) >> PATCH_SHIFT) << PATCH_SHIFT
    visits = np.zeros((height, width), np.uint8)
    hits = np.zeros((height, width), np.uint8)
    # OpenCV pixel (c, r) has its centre at integer coordinates: cell c spans [c-0.5, c+0.5).
    scale = float(1 << LINE_SHIFT)
    start = np.round((origin - (ix0, iy0) - 0.5) * scale)
    stop = np.round((ends_c - (ix0, iy0) - 0.5) * scale)
    segments = np.empty((len(ends), 2, 2), np.int32)
    segments[:, 0, :] = start
    segments[:, 1, :] = stop
    cv2.polylines(visits, segments, False, 1, 1, cv2.LINE_8, LINE_SHIFT)
    hit_cells = np.floor(ends_c[is_hit]).astype(np.int64) - (ix0, iy0)
    hits[hit_cells[:, 1], hit_cells[:, 0]] = 1
    visits[hit_cells[:, 1], hit_cells[:, 0]] = 1
    return ix0, iy0, hits, visits


def trace_scan_reference(laser_pose, ranges, angles, max_urange, max_range, resolution):
    """Slow, obvious per-beam ray tracer (test oracle for `trace_scan`).

    Walks each beam in small steps and collects the cells it passes. Returns
    (free_cells, hit_cells): sets of (ix, iy) crossed by some beam / ending a returned beam.
    """
    laser_pose = np.asarray(laser_pose, float)
    free, hit = set(), set()
    step = resolution / 20.0  # fine enough to not skip a corner-cut cell [m]
    for r, a in zip(ranges, angles):
        r = float(r)
        if r <= 0.0:
            continue
        returned = math.isfinite(r) and r < max_range and r < max_urange
        length = r if returned else max_urange
        th = laser_pose[2] + a
        n = int(length / step)
        for k in range(n + 1):
            d = k * step
            free.add((math.floor((laser_pose[0] + d * math.cos(th)) / resolution),
                      math.floor((laser_pose[1] + d * math.sin(th)) / resolution)))
        if returned:
            hit.add((math.floor((laser_pose[0] + r * math.cos(th)) / resolution),
                     math.floor((laser_pose[1] + r * math.sin(th)) / resolution)))
    return free, hit
