"""Copy-on-write patched occupancy grid (gmapping's ScanMatcherMap), its ray tracing compiled.

Reference: Grisetti, Stachniss, Burgard 2007, "Improved Techniques for Grid Mapping with
Rao-Blackwellized Particle Filters", IEEE T-RO 23(1); GMapping's HierarchicalArray2D
(grid/harray2d.h: patches allocated on demand, shared between particles through
reference-counted pointers) and PointAccumulator (grid/map.h: a cell's occupancy is
hits / visits, the "frequency" model). Ray tracing (integrate_scan) as in
ScanMatcher::registerScan with generateMap true (the published map):
every beam is traced on its own with a Bresenham line (GridLineTraversal) from the
laser's cell to the end cell; each cell before the end gets one visit, the end cell of a
beam that returned gets one hit and one visit. `add_hits` is registerScan with
generateMap false (the particles' maps, as slam_gmapping runs gmapping): end cells only.

Each cell also sums the points where beams ended in it (PointAccumulator's acc), so the
scan matcher can measure a beam's distance to the cell's mean hit point, not to its
centre: gmapping's sub-cell resolution. The sums are kept relative to the cell's own
corner (float32 stays precise however far the map reaches).

Readings as registerScan takes them: a range that is NaN, <= 0 or > maxRange (a +inf "no
return" among them) is skipped; one beyond maxUrange frees cells up to maxUrange and
marks no hit.

Counting per beam matters: with every cell counted at most once per scan, a free cell
just in front of a wall that one noisy beam ends in would score 1 hit / 1 visit for that
scan although dozens of beams crossed it; counted per beam it keeps a low frequency.

Memory: the world is cut into PATCH_CELLS x PATCH_CELLS patches, allocated only where a
beam passed. All patches of a filter live in one PatchPool (an array of (LAYERS, P, P)
float32 slots with reference counts): `copy()` shares every slot; a slot is duplicated
the first time one of the sharers writes to it (copy-on-write), so 100 particles whose
lineages merged cost little more than one map, and compiled code can read any
particle's cells through a small table of slot numbers (patch_table).

Ray tracing (`PatchGrid.integrate_scan`) is compiled ahead of time (C in
summit_nav_common/csrc/patch_grid.c, loaded by summit_nav_common.native: no numba, whose
LLVM would cost the node ~60-100 MB): the patches the scan's lines touch are made
writable, then every beam's Bresenham line is walked into them (`snc_trace_into`). `trace_scan` is the vectorized numpy version into a window and
`trace_scan_reference` the slow, obvious per-beam one: the test oracles.

Cell (i, j) covers world x in [i*res, (i+1)*res), y in [j*res, (j+1)*res): the grid's
origin is the world origin, indices may be negative. Arrays are indexed [row=y, col=x].
"""
import itertools
import math
from typing import Dict, Optional, Set, Tuple

import numpy as np
from summit_nav_common.line_cells import line_cells, line_cells_reference
from summit_nav_common.native import library as _native

PATCH_SHIFT = 4                  # log2 of the patch side [cells]
PATCH_CELLS = 1 << PATCH_SHIFT   # patch side, 16 cells = 0.8 m at 0.05 m [cells]: a particle copies
                                 # only the 4 KB patches its scan's end points fall in (a 64-cell
                                 # patch is 64 KB: Intel's offline peak was 205 MB, now 92 MB)
MAP_BLOCK_SHIFT = 6              # the published map grows in blocks of 64 cells (its extent is
                                 # that of 64-cell patches, whatever PATCH_SHIFT) [log2 cells]
HITS, VISITS, SUM_X, SUM_Y = range(4)  # layers: hit and visit counts, sums of the hit points'
                                 # offsets from the cell's lower-left corner [-, -, m, m]
LAYERS = 4                       # layers of a patch / a traced window [-]
COUNT_LIMIT = 1 << 22            # float32 counts stay exact; a patch's layers are halved (keeps
                                 # frequencies and mean hit points) before a cell's visits pass this [-]
FULLNESS_THRESHOLD = 0.1         # gmapping's m_fullnessThreshold: occupied for matching if hits/visits > this [-]
PATCH_BYTES = LAYERS * 4 * PATCH_CELLS * PATCH_CELLS  # float32 layers [bytes]
POOL_SLOTS = 256                 # initial PatchPool capacity; it doubles when full [patches]
FILTER_POOL_BYTES = 1 << 30      # address space the filter's pool takes at once [bytes]: pages
                                 # never written cost no memory, and a pool that doubles copies
                                 # itself, holding old and new at once (+64 MB at Intel's peak)
UNKNOWN = -1                     # OccupancyGrid value of a never-seen cell
OCCUPIED = 100                   # OccupancyGrid value of an occupied cell
FREE = 0                         # OccupancyGrid value of a free cell

Key = Tuple[int, int]


class PatchPool:
    """Reference-counted storage of patches: slot s is store[s], (LAYERS, P, P) float32.

    Grows by doubling (np.zeros: untouched slots cost no resident memory). Slots are
    numbers, not views, so a grid stays valid when the store is reallocated. Freed slots
    are reused first (last freed, first reused), so the pages written stay those of the
    most patches ever held at once.
    """

    def __init__(self, capacity: int = POOL_SLOTS):
        self.store = np.zeros((capacity, LAYERS, PATCH_CELLS, PATCH_CELLS), np.float32)
        self.refs = np.zeros(capacity, np.int64)
        self._free = []          # released slots
        self._next = 0           # slots from here on were never used

    def alloc(self, source: Optional[int] = None) -> int:
        """A new slot with one reference, zeroed or a copy of slot `source`."""
        if self._free:
            slot = self._free.pop()
        else:
            if self._next == len(self.refs):
                self._grow()
            slot = self._next
            self._next += 1
        if source is None:
            self.store[slot] = 0.0
        else:
            self.store[slot] = self.store[source]
        self.refs[slot] = 1
        return slot

    def release(self, slot: int) -> None:
        """Drop one reference; the slot is reused once none is left."""
        self.refs[slot] -= 1
        if self.refs[slot] == 0:
            self._free.append(slot)

    def used(self) -> int:
        """Slots in use [patches]."""
        return self._next - len(self._free)

    def _grow(self):
        old = len(self.refs)
        store = np.zeros((2 * old,) + self.store.shape[1:], np.float32)
        store[:old] = self.store
        self.store = store
        self.refs = np.concatenate((self.refs, np.zeros(old, np.int64)))


class PatchGrid:
    """Occupancy grid made of on-demand (hits, visits, hit sums) patches, shared copy-on-write.

    resolution: cell side [m]; pool: the PatchPool to keep patches in (a new one if None;
    grids that share patches share the pool). Use `copy()` to give another particle the
    same map and `release()` (or let it be garbage collected) when a map is dropped.
    """

    def __init__(self, resolution: float, pool: Optional[PatchPool] = None):
        if not resolution > 0.0:
            raise ValueError(f"grid resolution must be > 0 m, got {resolution!r}")
        self.resolution = float(resolution)
        self.pool = PatchPool() if pool is None else pool
        self._patches: Dict[Key, int] = {}  # (py, px) -> pool slot

    # ----------------------------------------------------------------- sharing
    def copy(self) -> "PatchGrid":
        """A grid equal to this one sharing all patches (nothing is copied until written)."""
        other = PatchGrid(self.resolution, self.pool)
        other._patches = dict(self._patches)
        for slot in self._patches.values():
            self.pool.refs[slot] += 1
        return other

    def release(self) -> None:
        """Give up this grid's patches (it is empty afterwards)."""
        patches, self._patches = self._patches, {}
        for slot in patches.values():
            self.pool.release(slot)

    def __del__(self):
        try:
            self.release()
        except Exception:  # interpreter shutdown: the pool may be gone already
            pass

    def patch_count(self) -> int:
        """Number of allocated patches this grid references."""
        return len(self._patches)

    def owned_patch_count(self) -> int:
        """Number of patches this grid may write without copying."""
        return sum(1 for s in self._patches.values() if self.pool.refs[s] == 1)

    def patch_ids(self) -> Set[int]:
        """Pool slots referenced (to count shared memory once)."""
        return set(self._patches.values())

    def shares_patch_with(self, other: "PatchGrid", key: Key) -> bool:
        """True when both grids reference the very same patch memory at `key`."""
        return (key in self._patches and self.pool is other.pool
                and self._patches[key] == other._patches.get(key))

    def _writable_slot(self, key: Key) -> int:
        slot = self._patches.get(key)
        if slot is None:
            slot = self.pool.alloc()
        elif self.pool.refs[slot] > 1:
            self.pool.release(slot)
            slot = self.pool.alloc(source=slot)
        else:
            return slot
        self._patches[key] = slot
        return slot

    def _writable_table(self, keys: np.ndarray):
        """Make the patches keys (M, 2) [py, px] writable (allocated or copied); (py0, px0,
        cols, slots) of a table of those patches only (as patch_table's), enough for a
        kernel that writes nowhere else."""
        slots = np.array([self._writable_slot((py, px)) for py, px in keys.tolist()], np.int64)
        (py0, px0), (py1, px1) = keys.min(axis=0), keys.max(axis=0)
        rows, cols = int(py1 - py0 + 1), int(px1 - px0 + 1)
        table = np.full(rows * cols, -1, np.int64)
        table[(keys[:, 0] - py0) * cols + (keys[:, 1] - px0)] = slots
        return int(py0), int(px0), cols, table

    def patch_table(self):
        """(py0, px0, rows, cols, slots (rows*cols,) int64): the pool slot of patch
        (py0 + r, px0 + c) at slots[r * cols + c], -1 where none is allocated."""
        if not self._patches:
            return 0, 0, 1, 1, np.full(1, -1, np.int64)
        keys = self._key_array()
        slots = np.fromiter(self._patches.values(), np.int64, len(self._patches))
        (py0, px0), (py1, px1) = keys.min(axis=0), keys.max(axis=0)
        rows, cols = int(py1 - py0 + 1), int(px1 - px0 + 1)
        table = np.full(rows * cols, -1, np.int64)
        table[(keys[:, 0] - py0) * cols + (keys[:, 1] - px0)] = slots
        return int(py0), int(px0), rows, cols, table

    def _key_array(self) -> np.ndarray:
        """The allocated patches' keys (M, 2) int64 [py, px], in the dict's order."""
        n = len(self._patches)
        return np.fromiter(itertools.chain.from_iterable(self._patches), np.int64, 2 * n).reshape(n, 2)

    # ------------------------------------------------------------ coordinates
    def world_to_cell(self, xy: np.ndarray) -> np.ndarray:
        """Integer cell indices (..., 2) [col, row] of world points (..., 2) [m]."""
        return np.floor(np.asarray(xy, float) / self.resolution).astype(np.int64)

    def bounds(self) -> Optional[Tuple[int, int, int, int]]:
        """Allocated extent (ix0, iy0, ix1, iy1) in cells, half-open, in whole blocks of
        2^MAP_BLOCK_SHIFT cells; None if empty."""
        if not self._patches:
            return None
        blocks = self._key_array() >> (MAP_BLOCK_SHIFT - PATCH_SHIFT)
        return (int(blocks[:, 1].min()) << MAP_BLOCK_SHIFT, int(blocks[:, 0].min()) << MAP_BLOCK_SHIFT,
                (int(blocks[:, 1].max()) + 1) << MAP_BLOCK_SHIFT, (int(blocks[:, 0].max()) + 1) << MAP_BLOCK_SHIFT)

    # ---------------------------------------------------------------- windows
    def read_window(self, ix0: int, iy0: int, width: int, height: int) -> Tuple[np.ndarray, np.ndarray]:
        """(hits, visits), each (height, width) float32, of the cells from (ix0, iy0).

        Unallocated cells read as 0 visits (unknown). Any window is allowed; it is fastest
        when aligned to patches.
        """
        cells = self.read_layers(ix0, iy0, width, height)
        return cells[HITS], cells[VISITS]

    def read_layers(self, ix0: int, iy0: int, width: int, height: int, layers: int = LAYERS) -> np.ndarray:
        """The first `layers` layers (layers, height, width) float32 (HITS, VISITS, SUM_X,
        SUM_Y) of the cells from (ix0, iy0).

        The patches the window touches are copied in one scatter into a patch-aligned
        buffer, which is then cut to the window (a map's window holds thousands of patches:
        copying them one by one in Python cost more than the ray casting)."""
        py0, px0 = iy0 >> PATCH_SHIFT, ix0 >> PATCH_SHIFT
        rows = ((iy0 + height - 1) >> PATCH_SHIFT) - py0 + 1
        cols = ((ix0 + width - 1) >> PATCH_SHIFT) - px0 + 1
        keys, slots = self._patches_in(py0, px0, rows, cols)
        buf = np.zeros((layers, rows, PATCH_CELLS, cols, PATCH_CELLS), np.float32)
        # the two index arrays, split by a slice, put the patch axis first: (K, layers, P, P)
        buf[:, keys[:, 0] - py0, :, keys[:, 1] - px0, :] = self.pool.store[slots, :layers]
        buf = buf.reshape(layers, rows * PATCH_CELLS, cols * PATCH_CELLS)
        oy, ox = iy0 - (py0 << PATCH_SHIFT), ix0 - (px0 << PATCH_SHIFT)
        if (oy, ox, height, width) == (0, 0) + buf.shape[1:]:
            return buf
        return buf[:, oy:oy + height, ox:ox + width].copy()

    def _patches_in(self, py0: int, px0: int, rows: int, cols: int) -> Tuple[np.ndarray, np.ndarray]:
        """(keys (K, 2) [py, px], pool slots (K,)) of the allocated patches in rows x cols
        patches from (py0, px0), found by whichever is shorter: the window or the grid."""
        if rows * cols <= len(self._patches):
            found = [(py, px, self._patches[py, px]) for py in range(py0, py0 + rows)
                     for px in range(px0, px0 + cols) if (py, px) in self._patches]
            arr = np.array(found, np.int64).reshape(-1, 3)
            return arr[:, :2], arr[:, 2]
        keys = self._key_array().reshape(-1, 2)
        slots = np.fromiter(self._patches.values(), np.int64, len(self._patches))
        inside = ((keys[:, 0] >= py0) & (keys[:, 0] < py0 + rows) & (keys[:, 1] >= px0) & (keys[:, 1] < px0 + cols))
        return keys[inside], slots[inside]

    def mean_hit(self, ix: int, iy: int) -> Optional[Tuple[float, float]]:
        """World point (x, y) [m] that the hits of cell (ix, iy) average to; None without hits."""
        cell = self.read_layers(ix, iy, 1, 1)[:, 0, 0]
        if cell[HITS] <= 0.0:
            return None
        return (ix * self.resolution + float(cell[SUM_X]) / float(cell[HITS]),
                iy * self.resolution + float(cell[SUM_Y]) / float(cell[HITS]))

    def add_window(self, ix0: int, iy0: int, counts: np.ndarray) -> None:
        """Add per-cell layers (LAYERS, h, w) (as trace_scan makes them) at cell (ix0, iy0).

        Only patches where the visits are non-zero are touched (allocated or copied).
        """
        _, height, width = counts.shape
        for key, (wy, wx, py, px, h, w) in _patch_slices(ix0, iy0, width, height):
            win = counts[:, wy:wy + h, wx:wx + w]
            if not win[VISITS].any():
                continue
            patch = self.pool.store[self._writable_slot(key)]
            if float(patch[VISITS].max()) + float(win[VISITS].max()) > COUNT_LIMIT:
                patch *= 0.5   # the frequency hits/visits and the mean hit point stay
            patch[:, py:py + h, px:px + w] += win

    # ------------------------------------------------------------ ray tracing
    def integrate_scan(self, laser_pose: np.ndarray, ranges: np.ndarray, angles: np.ndarray,
                       max_urange: float, max_range: float, no_hit: Optional[np.ndarray] = None) -> None:
        """Ray-trace one scan from laser_pose (x [m], y [m], theta [rad]) into the grid.

        ranges (n,) [m], angles (n,) [rad] in the laser frame. A beam with a range <
        max_urange (and <= max_range) marks its end cell hit at its end point; one in
        [max_urange, max_range] only frees cells up to max_urange; a range that is NaN,
        <= 0 or > max_range (+inf: no return) is skipped, as gmapping's registerScan does.
        no_hit (n,) bool: beams that only free the cells before their end, as one cut at
        max_urange (a mixed pixel's line of sight is free, its end point is no surface).
        """
        laser_pose = np.asarray(laser_pose, float)
        ends, is_hit = beam_endpoints(laser_pose, ranges, angles, max_urange, max_range, no_hit)
        if len(ends) == 0:
            return
        res = self.resolution
        start = np.floor(laser_pose[:2] / res).astype(np.int64)
        end_cells = np.floor(ends / res).astype(np.int64)
        py0, px0, cols, table = self._writable_table(_touched_patches(start, end_cells))
        _native().snc_trace_into(self.pool.store, PATCH_SHIFT, table, py0, px0, cols, start, end_cells,
                                 np.ascontiguousarray(ends), is_hit.view(np.uint8), len(end_cells), res,
                                 float(COUNT_LIMIT))

    def add_hits(self, laser_pose: np.ndarray, ranges: np.ndarray, angles: np.ndarray,
                 max_urange: float, max_range: float) -> None:
        """Mark only the end cells of one scan's returned beams (a hit, a visit and the end
        point each), nothing along the beams: gmapping's registerScan with generateMap
        false, how slam_gmapping builds its particles' maps. A beam is used when 0 < r <=
        max_urange and r <= max_range.
        """
        laser_pose = np.asarray(laser_pose, float)
        r = np.asarray(ranges, float)
        with np.errstate(invalid="ignore"):
            used = (r > 0.0) & (r <= max_urange) & (r <= max_range)
        if not used.any():
            return
        a = laser_pose[2] + np.asarray(angles, float)[used]
        ends = np.column_stack((laser_pose[0] + r[used] * np.cos(a), laser_pose[1] + r[used] * np.sin(a)))
        cells = np.floor(ends / self.resolution).astype(np.int64)
        py0, px0, cols, table = self._writable_table(_unique_keys(cells >> PATCH_SHIFT))
        _native().snc_add_hits_into(self.pool.store, PATCH_SHIFT, table, py0, px0, cols, cells, np.ascontiguousarray(ends),
                                    len(cells), self.resolution, float(COUNT_LIMIT))

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
        counts = self.read_layers(ix0, iy0, width, height, layers=VISITS + 1)
        data = occupancy_values(counts[HITS], counts[VISITS], occ_thresh)
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
        for slot in self._patches.values():
            patch = self.pool.store[slot]
            total += float(cell_entropy(patch[HITS], patch[VISITS]).sum())
        return total

    def nbytes(self) -> int:
        """Bytes of patch memory referenced by this grid (shared patches included)."""
        return len(self._patches) * PATCH_BYTES


# ------------------------------------------------------------------ helpers
def _unique_keys(patch_xy: np.ndarray) -> np.ndarray:
    """The distinct rows of patch_xy (M, 2) [px, py] as keys (K, 2) [py, px] (one 1-D
    np.unique of packed 64-bit keys: several times faster than np.unique(axis=0))."""
    packed = np.unique((patch_xy[:, 1] << 32) | (patch_xy[:, 0] & 0xFFFFFFFF))
    px = packed & 0xFFFFFFFF
    return np.column_stack((packed >> 32, np.where(px >= 1 << 31, px - (1 << 32), px)))


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
                   max_urange: float, max_range: float, no_hit: Optional[np.ndarray] = None):
    """Classify beams and compute ray ends in the world (gmapping's registerScan).

    Returns (ends (K, 2) [m] of the used beams, is_hit (K,) bool): a beam with 0 < r <=
    max_range is used; it ends at r and is a hit when r < max_urange (and not no_hit,
    (n,) bool, when given), else it ends at min(r, max_urange). NaN, r <= 0 and r >
    max_range (+inf, no return) are dropped.
    """
    r = np.asarray(ranges, float)
    with np.errstate(invalid="ignore"):
        used = (r > 0.0) & (r <= max_range)          # False for NaN
    is_hit = used & (r < max_urange)
    if no_hit is not None:
        is_hit &= ~np.asarray(no_hit, bool)
    length = np.minimum(r[used], max_urange)
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
    round(k * d / n), halves rounded up: summit_nav_common.line_cells, ties "up".
    """
    beam, x, y = line_cells(start[:, 0], start[:, 1], stop[:, 0], stop[:, 1], ties="up")
    return np.column_stack([x, y]), beam


def trace_scan(laser_pose, ranges, angles, max_urange, max_range, resolution, no_hit=None):
    """Rasterize a scan into (ix0, iy0, counts (LAYERS, h, w) float32), patch-aligned.

    Per beam (gmapping's registerScan): the Bresenham line from the laser's cell to the end
    cell; every cell but the last gets a visit; the end cell of a returned beam gets a hit,
    a visit and its end point (offset from the cell's corner) added to the sums. A beam cut
    at max_urange leaves its last cell untouched, as in gmapping.
    """
    laser_pose = np.asarray(laser_pose, float)
    ends, is_hit = beam_endpoints(laser_pose, ranges, angles, max_urange, max_range, no_hit)
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
    hit_cells = flat[last[is_hit]]
    counts[HITS] = np.bincount(hit_cells, minlength=size)
    counts[VISITS] += counts[HITS]
    offsets = ends[is_hit] - end_cells[is_hit] * resolution   # from the cell's corner [m]
    counts[SUM_X] = np.bincount(hit_cells, weights=offsets[:, 0], minlength=size)
    counts[SUM_Y] = np.bincount(hit_cells, weights=offsets[:, 1], minlength=size)
    return ix0, iy0, counts.reshape(LAYERS, height, width)


def trace_scan_reference(laser_pose, ranges, angles, max_urange, max_range, resolution, no_hit=None):
    """Slow, obvious per-beam ray tracer (test oracle for `trace_scan`).

    For each beam, a plain Bresenham walk (one cell per step of the major axis, the minor
    coordinate rounded) from the laser's cell to the end cell. Returns a dict
    {(ix, iy): [hits, visits, sum_x, sum_y]} as trace_scan's layers.
    """
    laser_pose = np.asarray(laser_pose, float)
    out = {}

    def cell(key):
        return out.setdefault(key, [0.0] * LAYERS)

    x0 = math.floor(laser_pose[0] / resolution)
    y0 = math.floor(laser_pose[1] / resolution)
    flags = np.zeros(len(ranges), bool) if no_hit is None else np.asarray(no_hit, bool)
    for r, a, free_only in zip(ranges, angles, flags):
        r = float(r)
        if not 0.0 < r <= max_range:   # NaN, <= 0, beyond maxRange (+inf): skipped
            continue
        returned = r < max_urange and not free_only
        length = min(r, max_urange)
        th = laser_pose[2] + a
        ex = laser_pose[0] + length * math.cos(th)
        ey = laser_pose[1] + length * math.sin(th)
        x1, y1 = math.floor(ex / resolution), math.floor(ey / resolution)
        for c in line_cells_reference(x0, y0, x1, y1, ties="up")[:-1]:   # the end cell apart
            cell(c)[VISITS] += 1
        if returned:
            c = cell((x1, y1))
            c[HITS] += 1
            c[VISITS] += 1
            c[SUM_X] += ex - x1 * resolution
            c[SUM_Y] += ey - y1 * resolution
    return out


# ------------------------------------------------------------ compiled tracing
def _touched_patches(start, end_cells):
    """Patch keys (M, 2) [py, px], in increasing order, that the Bresenham lines from cell
    start (2,) to end_cells (B, 2) pass (the walk is snc_touched_patches)."""
    lo = np.minimum(end_cells.min(axis=0), start) >> PATCH_SHIFT
    hi = np.maximum(end_cells.max(axis=0), start) >> PATCH_SHIFT
    px0, py0 = int(lo[0]), int(lo[1])
    cols, rows = int(hi[0]) - px0 + 1, int(hi[1]) - py0 + 1
    mark = np.zeros(rows * cols, np.uint8)
    _native().snc_touched_patches(PATCH_SHIFT, np.ascontiguousarray(start, np.int64), end_cells, len(end_cells), py0, px0,
                                  cols, mark)
    idx = np.flatnonzero(mark)
    return np.column_stack((idx // cols + py0, idx % cols + px0))
