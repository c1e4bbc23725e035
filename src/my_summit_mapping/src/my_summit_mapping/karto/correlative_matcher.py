"""Multi-resolution correlative scan matching with a response and a covariance.

Reference: E. Olson, "Real-Time Correlative Scan Matching", ICRA 2009 (a lookup table of
smeared hits, an exhaustive search over x, y, theta, the covariance from the response
surface, and a coarse-to-fine search whose coarse level bounds the fine one); open_karto's
ScanMatcher (Konolige et al. 2010, "Efficient Sparse Pose Adjustment for 2D Mapping") for
the search pattern, the response and its penalties, as its documentation describes them.

What the code does, in the order it runs:
1. `LookupGrid.build`: the reference points (map frame) mark their cells; each marked
   cell spreads a Gaussian kernel (std `smear_deviation`, half width round(2 sigma / res)
   cells, peak GRID_OCCUPIED) and a cell keeps the largest value any kernel gives it.
2. `correlate`: for every heading of the search, the scan's points (base frame) are
   turned once and their cells computed once; each x-y offset of the search is an
   integer shift of those cells, so the response of all offsets of a heading is one
   gather from the grid. Response = sum of grid values / (points * GRID_OCCUPIED) in
   [0, 1], multiplied, when penalized, by open_karto's distance and angle penalties
   (1 - 0.2 d^2 / distance_variance_penalty, at least minimum_distance_penalty; the same
   for the heading).
3. The estimate is the mean of the poses whose response ties the best. Its covariance
   is the response-weighted spread (Olson 2009, sec. IV-C) of the positions whose
   response (best over headings) lies within COVARIANCE_RESPONSE_BAND of the best, and
   of the headings at the best position, divided by the best response; in no direction
   below a tenth of a search cell squared. Unpenalized, a response still within the band
   at the window's edge spreads beyond it: that axis's variance is raised to the
   window's side squared (the window cannot tell more).
4. `ScanMatcher.match`: a coarse search over the whole window at twice the grid
   resolution and `coarse_angle_resolution`, then, when refining, a fine search around
   the coarse estimate at the grid resolution and `fine_search_angle_offset` (open_karto's
   two passes); the x-y covariance is the coarse pass's, whose window shows how the
   response spreads (along a corridor, say), the heading variance the fine pass's. Large windows (the loop-closure search) run the coarse pass as a
   branch and bound (`correlate_bounded`): blocks of offsets are scored first on a grid
   max-pooled over the block (an upper bound of every offset inside, Olson's low
   resolution table), and only blocks whose bound can still reach the best response (or
   the band of the covariance) are searched cell by cell; the result equals the
   exhaustive search's.

`correlate_reference` is the slow, obvious loop over poses and points: the test oracle.
"""
import math
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np
from summit_nav_common.native import library

GRID_OCCUPIED = 100              # value of a hit cell in the lookup grid [-]
DISTANCE_PENALTY_GAIN = 0.2      # open_karto's gain on the squared offset / variance [-]
ANGLE_PENALTY_GAIN = 0.2         # the same for the heading [-]
RESPONSE_TIE = 1e-6              # responses this close to the best are averaged (open_karto's KT_TOLERANCE) [-]
COVARIANCE_RESPONSE_BAND = 0.1   # poses within this of the best response make the covariance [-]
MIN_VARIANCE_FACTOR = 0.1        # variance floor: this * search step^2 [-]
MAX_VARIANCE = 500.0             # covariance diagonal of a scan that matched nothing [m^2, rad^2]
BLOCK_POSITIONS = 8              # branch and bound: offsets per block side [-]
BNB_MIN_POSITIONS = 1024         # below this many x-y offsets the coarse pass is exhaustive [-]


@dataclass(frozen=True)
class SearchSpace:
    """The x-y window and lookup grid of a matcher (open_karto's *_search_space_*)."""
    dimension: float        # side of the square x-y search window [m]
    resolution: float       # lookup grid cell and fine search step [m]
    smear_deviation: float  # std of the Gaussian a hit spreads in the grid [m]


@dataclass(frozen=True)
class MatcherSettings:
    """Search pattern and penalties (open_karto's names, radians)."""
    coarse_search_angle_offset: float = math.radians(20.0)  # +- heading window [rad]
    coarse_angle_resolution: float = math.radians(2.0)      # coarse heading step [rad]
    fine_search_angle_offset: float = math.radians(0.2)     # fine heading step [rad]
    distance_variance_penalty: float = 0.3 ** 2             # [m^2]
    angle_variance_penalty: float = math.radians(20.0) ** 2  # [rad^2]
    minimum_distance_penalty: float = 0.5                   # [-]
    minimum_angle_penalty: float = 0.9                      # [-]
    use_response_expansion: bool = False  # widen the heading window when nothing matched
    max_recenters: int = 0     # moves of the x-y window onto a best pose found at its edge (ours) [-]


@dataclass
class MatchResult:
    pose: np.ndarray        # (3,) best base pose in the map frame [m, m, rad]
    response: float         # [0, 1]
    covariance: np.ndarray  # (3, 3) [m^2, m^2, rad^2]


class LookupGrid:
    """Smeared hit grid (step 1 of the module docstring). values[row = y, col = x]."""

    def __init__(self, values: np.ndarray, origin: np.ndarray, resolution: float, margin: int):
        self.values = values              # uint8 (H, W)
        self.flat = values.reshape(-1)
        self.origin = origin              # map coordinates of cell (0, 0)'s lower-left corner [m]
        self.resolution = resolution      # [m]
        self.margin = margin              # lookups shift cells by at most this many cells [cells]

    @classmethod
    def build(cls, points: np.ndarray, resolution: float, smear_deviation: float,
              center: np.ndarray, half_extent: float, max_shift: int) -> "LookupGrid":
        """Grid of the reference points (M, 2) [m] within center +- half_extent [m].

        max_shift: the largest x-y shift [cells] a search will add to a point's cell;
        the grid keeps 2 * (max_shift + 1) empty cells around its hits so that clipped
        lookups (see cells_of) read zeros.
        """
        kernel = smear_kernel(resolution, smear_deviation)
        half = kernel.shape[0] // 2
        pts = np.asarray(points, float).reshape(-1, 2)
        inside = np.all(np.abs(pts - center) <= half_extent, axis=1)
        pts = pts[inside]
        margin = max_shift + 1
        pad = half + 2 * margin
        if len(pts) == 0:
            lo = np.floor(np.asarray(center, float) / resolution).astype(np.int64)
            hi = lo + 1
        else:
            cells = np.floor(pts / resolution).astype(np.int64)
            lo, hi = cells.min(axis=0), cells.max(axis=0) + 1
        lo, hi = lo - pad, hi + pad
        width, height = int(hi[0] - lo[0]), int(hi[1] - lo[1])
        values = np.zeros((height, width), np.uint8)
        if len(pts):
            cells = np.floor(pts / resolution).astype(np.int64) - lo
            hits = np.unique(cells[:, 1] * width + cells[:, 0])
            _stamp(values.reshape(-1), hits, kernel, width)
        return cls(values, lo * resolution, resolution, margin)

    def cells_of(self, xy: np.ndarray) -> np.ndarray:
        """Flat cell indices of points xy (..., 2) [m], clipped into the band `margin`
        cells inside the border: a point off the grid reads only empty cells, whatever
        shift of at most `margin` is added."""
        h, w = self.values.shape
        m = self.margin
        ix = np.clip(np.floor((xy[..., 0] - self.origin[0]) / self.resolution).astype(np.int64), m, w - 1 - m)
        iy = np.clip(np.floor((xy[..., 1] - self.origin[1]) / self.resolution).astype(np.int64), m, h - 1 - m)
        return iy * w + ix

    def value_at(self, x: float, y: float, shift_x: int = 0, shift_y: int = 0) -> int:
        """Value of the cell of map point (x, y) [m] moved by (shift_x, shift_y) [cells]
        (0 off the grid): the oracle's lookup."""
        ix = math.floor((x - self.origin[0]) / self.resolution) + shift_x
        iy = math.floor((y - self.origin[1]) / self.resolution) + shift_y
        h, w = self.values.shape
        return int(self.values[iy, ix]) if 0 <= ix < w and 0 <= iy < h else 0


def smear_kernel(resolution: float, smear_deviation: float) -> np.ndarray:
    """uint8 (2h+1, 2h+1) Gaussian kernel, h = round(2 sigma / res) cells, peak GRID_OCCUPIED."""
    half = max(int(round(2.0 * smear_deviation / resolution)), 0)
    i = np.arange(-half, half + 1) * resolution
    d2 = i[None, :] ** 2 + i[:, None] ** 2
    if smear_deviation <= 0.0:
        return np.full((1, 1), GRID_OCCUPIED, np.uint8)
    return np.round(GRID_OCCUPIED * np.exp(-0.5 * d2 / smear_deviation ** 2)).astype(np.uint8)


def _stamp(flat: np.ndarray, hits: np.ndarray, kernel: np.ndarray, width: int) -> None:
    """flat[c + k] = max(flat[c + k], kernel[k]) for every hit cell c (flat indices) and
    kernel offset k (compiled, csrc/correlation_grid.c: hits x kernel cells of small work
    each; _stamp_reference is its oracle)."""
    library().snc_stamp_max(flat, np.ascontiguousarray(hits, np.int64), len(hits),
                            np.ascontiguousarray(kernel, np.uint8), kernel.shape[0] // 2, int(width))


def _stamp_reference(flat: np.ndarray, hits: np.ndarray, kernel: np.ndarray, width: int) -> None:
    """_stamp in NumPy (the tests' oracle)."""
    half = kernel.shape[0] // 2
    for dy in range(kernel.shape[0]):
        for dx in range(kernel.shape[1]):
            idx = hits + (dy - half) * width + (dx - half)
            flat[idx] = np.maximum(flat[idx], kernel[dy, dx])


def _box_max(values: np.ndarray, extent: int) -> np.ndarray:
    """uint8 (H, W): out[y, x] = max of values[y:y + extent, x:x + extent], beyond the grid
    0 (compiled, csrc/correlation_grid.c; _box_max_reference is its oracle)."""
    src = np.ascontiguousarray(values, np.uint8)
    out = np.empty_like(src)
    if library().snc_box_max(src, src.shape[0], src.shape[1], int(extent), out) != 0:
        raise MemoryError(f"box maximum of a {src.shape[0]} x {src.shape[1]} grid: no memory for its buffer")
    return out


def _box_max_reference(values: np.ndarray, extent: int) -> np.ndarray:
    """_box_max in NumPy (the tests' oracle)."""
    h, w = values.shape
    padded = np.zeros((h + extent - 1, w + extent - 1), np.uint8)
    padded[:h, :w] = values
    out = np.zeros((h, w), np.uint8)
    for dy in range(extent):
        for dx in range(extent):
            out = np.maximum(out, padded[dy:dy + h, dx:dx + w])
    return out


def _penalties(dist2: np.ndarray, angle2: np.ndarray, s: MatcherSettings) -> Tuple[np.ndarray, np.ndarray]:
    dp = np.maximum(1.0 - DISTANCE_PENALTY_GAIN * dist2 / s.distance_variance_penalty, s.minimum_distance_penalty)
    ap = np.maximum(1.0 - ANGLE_PENALTY_GAIN * angle2 / s.angle_variance_penalty, s.minimum_angle_penalty)
    return dp, ap


def _offsets(half_cells: int, step_cells: int) -> np.ndarray:
    """x-y shifts (P, 2) [cells] of a square search, -half..half by step (x fastest)."""
    r = np.arange(-half_cells, half_cells + 1, step_cells)
    oy, ox = np.meshgrid(r, r, indexing="ij")
    return np.column_stack((ox.reshape(-1), oy.reshape(-1)))


def _angles(center_heading: float, offset: float, step: float) -> np.ndarray:
    n = int(round(2.0 * offset / step)) + 1 if step > 0 else 1
    return center_heading - offset + step * np.arange(n)


def _turned(points: np.ndarray, center: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Map points (A, n, 2) of base-frame points (n, 2) at position center[:2], headings (A,)."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    x = center[0] + c * points[None, :, 0] - s * points[None, :, 1]
    y = center[1] + s * points[None, :, 0] + c * points[None, :, 1]
    return np.stack((x, y), axis=-1)


def correlate(grid: LookupGrid, points: np.ndarray, center: np.ndarray, offsets: np.ndarray,
              angles: np.ndarray) -> np.ndarray:
    """Unpenalized responses (A, P) of base-frame points (n, 2) at position center[:2]
    shifted by offsets (P, 2) [cells], headings angles (A,) [rad]."""
    if len(points) == 0:
        return np.zeros((len(angles), len(offsets)))
    base = grid.cells_of(_turned(points, center, angles))           # (A, n)
    w = grid.values.shape[1]
    shift = offsets[:, 1] * w + offsets[:, 0]                          # (P,)
    return _correlate_sums(grid.flat, base, shift) / float(len(points) * GRID_OCCUPIED)


def _correlate_sums(flat: np.ndarray, base: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """int64 (A, P): the sum over points of flat[base[a, i] + shift[p]] (compiled,
    csrc/correlation_grid.c: one pass, no (A, P, n) index array; _correlate_sums_reference
    is its oracle). Every index must lie in flat (cells_of keeps them there)."""
    base = np.ascontiguousarray(base, np.int64).reshape(-1, base.shape[-1])
    shift = np.ascontiguousarray(shift, np.int64).reshape(-1)
    out = np.empty((base.shape[0], len(shift)), np.int64)
    if base.size and len(shift) and (base.min() + shift.min() < 0 or base.max() + shift.max() >= len(flat)):
        raise IndexError(f"a lookup falls outside the {len(flat)}-cell grid")   # what np.take would say
    library().snc_correlate_sums(flat, base, base.shape[0], base.shape[1], shift, len(shift), out)
    return out


def _correlate_sums_reference(flat: np.ndarray, base: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """_correlate_sums in NumPy (the tests' oracle)."""
    base = np.asarray(base).reshape(-1, base.shape[-1])
    return np.take(flat, base[:, None, :] + np.asarray(shift)[None, :, None]).sum(axis=2, dtype=np.int64)


def correlate_bounded(grid: LookupGrid, points: np.ndarray, center: np.ndarray, offsets_half: int,
                      step: int, angles: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """correlate() over the square of shifts -offsets_half..offsets_half by step [cells],
    by branch and bound (module docstring, step 4). Returns (A, P) responses as correlate's,
    with NaN where a block was pruned: every response >= max(best, floor) -
    COVARIANCE_RESPONSE_BAND is exact (floor: responses below it are not wanted)."""
    offsets = _offsets(offsets_half, step)
    side = 2 * offsets_half // step + 1
    out = np.full((len(angles), side * side), np.nan)
    if len(points) == 0:
        out[:] = 0.0
        return out
    b = BLOCK_POSITIONS
    extent = (b - 1) * step + 1                                        # cells a block's shifts span
    pooled = _box_max(grid.values, extent)
    base = grid.cells_of(_turned(points, center, angles))             # (A, n)
    w = grid.values.shape[1]
    n_blocks = -(-side // b)
    bi = np.arange(n_blocks) * b                                       # first index of each block
    by, bx = np.meshgrid(bi, bi, indexing="ij")
    corner_cells = np.column_stack((bx.reshape(-1), by.reshape(-1))) * step - offsets_half
    shift = corner_cells[:, 1] * w + corner_cells[:, 0]
    bound = _correlate_sums(pooled.reshape(-1), base, shift) / float(len(points) * GRID_OCCUPIED)   # (A, blocks)
    order = np.argsort(-bound, axis=None)
    best = -1.0
    idx_grid = np.arange(side * side).reshape(side, side)
    for flat_i in order:
        a, k = divmod(int(flat_i), bound.shape[1])
        if bound[a, k] < max(best, floor) - COVARIANCE_RESPONSE_BAND:
            break
        y0, x0 = by.reshape(-1)[k], bx.reshape(-1)[k]
        cols = idx_grid[y0:y0 + b, x0:x0 + b].reshape(-1)
        r = _correlate_sums(grid.flat, base[a:a + 1], offsets[cols, 1] * w + offsets[cols, 0])[0] \
            / float(len(points) * GRID_OCCUPIED)
        out[a, cols] = r
        best = max(best, float(r.max()))
    return out


def correlate_reference(grid: LookupGrid, points: np.ndarray, center: np.ndarray, offsets: np.ndarray,
                        angles: np.ndarray) -> np.ndarray:
    """Slow, obvious correlate(): every pose, every point, one grid lookup each."""
    out = np.zeros((len(angles), len(offsets)))
    res = grid.resolution
    for a, th in enumerate(angles):
        c, s = math.cos(th), math.sin(th)
        for p, (ox, oy) in enumerate(offsets):
            total = 0
            for px, py in points:
                x = center[0] + c * px - s * py
                y = center[1] + s * px + c * py
                total += grid.value_at(x, y, int(ox), int(oy))
            out[a, p] = total / (len(points) * GRID_OCCUPIED) if len(points) else 0.0
    return out


def floor_eigenvalues(cov: np.ndarray, floor: float) -> np.ndarray:
    """Symmetric cov (k, k) with every eigenvalue raised to at least floor: no direction,
    not only the axes, ends up tighter than the search can tell (a diagonal corridor's
    spread is nearly singular)."""
    w, v = np.linalg.eigh(0.5 * (cov + cov.T))
    return (v * np.maximum(w, floor)) @ v.T


def estimate(responses: np.ndarray, offsets: np.ndarray, angles: np.ndarray, center: np.ndarray,
             resolution: float, step_xy: float, step_angle: float,
             penalty_center: Optional[np.ndarray], settings: MatcherSettings) -> MatchResult:
    """Best pose, response and covariance (module docstring, step 3) from responses (A, P)
    (NaN: not evaluated) at center + offsets * resolution, headings angles."""
    resp = np.nan_to_num(responses, nan=-1.0)
    xy = center[:2] + offsets * resolution                            # (P, 2)
    if penalty_center is not None:
        d2 = np.sum((xy - penalty_center[:2]) ** 2, axis=1)
        a2 = (angles - penalty_center[2]) ** 2
        dp, ap = _penalties(d2, a2, settings)
        resp = np.where(resp >= 0.0, resp * dp[None, :] * ap[:, None], resp)
    best = float(resp.max())
    if best <= RESPONSE_TIE:
        return MatchResult(np.array([center[0], center[1], angles[len(angles) // 2]]), max(best, 0.0),
                           np.diag([MAX_VARIANCE, MAX_VARIANCE, MAX_VARIANCE]))
    ties_a, ties_p = np.nonzero(resp >= best - RESPONSE_TIE)
    mean_xy = xy[ties_p].mean(axis=0)
    mean_th = float(np.mean(angles[ties_a]))
    cov = np.zeros((3, 3))
    pos = resp.max(axis=0)
    near = pos >= best - COVARIANCE_RESPONSE_BAND
    w = pos[near]
    d = xy[near] - mean_xy
    cov[:2, :2] = (d.T * w) @ d / w.sum()
    p_best = int(ties_p[0])
    col = resp[:, p_best]
    near_a = col >= best - COVARIANCE_RESPONSE_BAND
    wa = col[near_a]
    cov[2, 2] = float(np.sum(wa * (angles[near_a] - mean_th) ** 2) / wa.sum())
    cov /= best
    if penalty_center is None:
        # an unpenalized response still this high at the window's edge goes on beyond it:
        # the window cannot tell how far, so along that axis the match tells little
        reach = np.abs(offsets).max(axis=0)
        for axis in (0, 1):
            if np.any(near & (np.abs(offsets[:, axis]) >= reach[axis])):
                cov[axis, axis] = max(cov[axis, axis], (2.0 * reach[axis] * resolution) ** 2)
    cov[:2, :2] = floor_eigenvalues(cov[:2, :2], MIN_VARIANCE_FACTOR * step_xy ** 2)
    cov[2, 2] = max(cov[2, 2], MIN_VARIANCE_FACTOR * step_angle ** 2)
    return MatchResult(np.array([mean_xy[0], mean_xy[1], math.atan2(math.sin(mean_th), math.cos(mean_th))]),
                       best, cov)


class ScanMatcher:
    """Coarse-to-fine correlative matcher over one search space (module docstring)."""

    def __init__(self, search: SearchSpace, settings: MatcherSettings, range_threshold: float):
        self.search = search
        self.settings = settings
        self.range_threshold = range_threshold   # reference points farther than this from
                                                 # the search centre cannot match [m]
        self.half_cells = int(round(0.5 * search.dimension / search.resolution))

    def grid(self, reference_points: np.ndarray, center: np.ndarray) -> LookupGrid:
        """The lookup grid of reference points (M, 2) around a search centre (3,)."""
        s = self.search
        return LookupGrid.build(reference_points, s.resolution, s.smear_deviation, np.asarray(center[:2], float),
                                self.range_threshold + 0.5 * s.dimension + s.resolution,
                                self.half_cells + 1)

    def _recenter(self, grid, points, center, result, pen) -> MatchResult:
        """While the coarse best lies on the x-y window's edge (the optimum may lie beyond)
        search a window centred on it, up to settings.max_recenters times, keeping the
        penalty centred on the prediction; stop when the response no longer grows."""
        s, st = self.search, self.settings
        step = 2
        edge = (self.half_cells - step) * s.resolution
        search_center = center
        offsets = _offsets(self.half_cells, step)
        for _ in range(st.max_recenters):
            if np.max(np.abs(result.pose[:2] - search_center[:2])) < edge - 1e-9:
                break
            search_center = result.pose
            angles = _angles(search_center[2], st.coarse_search_angle_offset, st.coarse_angle_resolution)
            resp = correlate(grid, points, search_center, offsets, angles)
            moved = estimate(resp, offsets, angles, search_center, s.resolution, step * s.resolution,
                             st.coarse_angle_resolution, pen, st)
            if moved.response <= result.response:
                break
            result = moved
        return result

    def match(self, points: np.ndarray, reference_points: np.ndarray, center: np.ndarray,
              penalize: bool = True, refine: bool = True, grid: Optional[LookupGrid] = None,
              min_response: float = 0.0) -> MatchResult:
        """Best pose of base-frame points (n, 2) against reference points (M, 2) near the
        predicted pose center (3,) [m, m, rad]. min_response: the coarse pass may skip
        poses that cannot reach it (the result is then only meaningful above it)."""
        center = np.asarray(center, float)
        grid = grid if grid is not None else self.grid(reference_points, center)
        s, st = self.search, self.settings
        pen = center if penalize else None
        coarse_step = 2
        angle_offset = st.coarse_search_angle_offset
        for _ in range(4 if st.use_response_expansion else 1):
            angles = _angles(center[2], angle_offset, st.coarse_angle_resolution)
            offsets = _offsets(self.half_cells, coarse_step)
            if len(offsets) >= BNB_MIN_POSITIONS:
                resp = correlate_bounded(grid, points, center, self.half_cells, coarse_step, angles, min_response)
            else:
                resp = correlate(grid, points, center, offsets, angles)
            result = estimate(resp, offsets, angles, center, s.resolution, coarse_step * s.resolution,
                              st.coarse_angle_resolution, pen, st)
            if result.response > RESPONSE_TIE:
                break
            angle_offset += st.coarse_search_angle_offset   # open_karto's response expansion
        result = self._recenter(grid, points, center, result, pen)
        if not refine or result.response <= RESPONSE_TIE:
            return result
        fine_center = result.pose
        angles = _angles(fine_center[2], 0.5 * st.coarse_angle_resolution, st.fine_search_angle_offset)
        offsets = _offsets(coarse_step // 2, 1)
        resp = correlate(grid, points, fine_center, offsets, angles)
        fine = estimate(resp, offsets, angles, fine_center, s.resolution, s.resolution,
                        st.fine_search_angle_offset, pen, st)
        # the fine window is a cell wide: only the coarse surface shows how the response
        # spreads in x-y (a corridor's length); the heading's spread shows at the fine
        # pass's steps (the coarse ones, 2 deg, are wider than a good match's doubt)
        cov = result.covariance.copy()
        cov[2, 2] = fine.covariance[2, 2]
        return MatchResult(fine.pose, fine.response, cov)
