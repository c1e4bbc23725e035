"""Grid operations the planners and costmaps need, compiled (csrc/) instead of OpenCV's.

Debian's cv2 maps about 95 MB of shared libraries into a process (GDAL, VTK, Qt,
Tesseract, ...) for the handful of operations below, which kept move_base far above
Python's floor (issue 43). Each function returns what the OpenCV call it replaced
returned, to the bit (test_grid_kernels.py checks each against cv2, the oracle, which
stays a test-only import):

- ``distance_transform(src)``: cv2.distanceTransform(src, DIST_L2, DIST_MASK_PRECISE),
  the exact Euclidean distance [cells] of each cell to the nearest zero cell (float32).
- ``chamfer_labels(src)``: cv2.distanceTransformWithLabels(src, DIST_L2, DIST_MASK_5,
  labelType=DIST_LABEL_PIXEL): the 5x5 chamfer distance and the label of the zero cell it
  comes from (zero cells numbered 1, 2, ... in raster order).
- ``remap_bilinear(field, fx, fy, border)``: cv2.remap(field, fx, fy, INTER_LINEAR,
  borderMode=BORDER_CONSTANT, borderValue=border) for float32 maps of any shape.
- ``upsample_linear(grid, k)``: cv2.resize(grid, (w k, h k), interpolation=INTER_LINEAR).
- ``dilate3(grid)``, ``erode3(grid)``: cv2.dilate / cv2.erode with a 3x3 square and the
  default border (cells off the grid ignored); NumPy, exact for any dtype.
- ``fill_rays(grid, x0, y0, x1, y1, supersample, value)``: sets the cells under straight
  rays sampled `supersample` times per cell (no OpenCV counterpart: the costmaps'
  clearing, whose NumPy walk is its oracle; see csrc/raytrace.c).
- ``components8(mask)``: 8-connected components of the nonzero cells (labels 1.. by
  first cell in raster order, 0 elsewhere), for what connectedComponents and floodFill
  were used for: which cells are joined.
"""
import numpy as np

from .native import library


def _u8(mask):
    return np.ascontiguousarray(mask, dtype=np.uint8)


def distance_transform(src):
    """(H, W) float32 exact Euclidean distance [cells] of each cell to the nearest cell
    where src == 0 (about 3.2e7 everywhere when src has no zero cell, as OpenCV's)."""
    src = _u8(src)
    h, w = src.shape
    out = np.empty((h, w), np.float32)
    if h and w and library().snc_edt(src, h, w, out):
        raise MemoryError("distance_transform: out of memory")
    return out


def chamfer_labels(src):
    """((H, W) float32 5x5 chamfer distance [cells], (H, W) int32 label of the nearest
    zero cell) of src (zero cells are the sources)."""
    src = _u8(src)
    h, w = src.shape
    dist = np.empty((h, w), np.float32)
    labels = np.empty((h, w), np.int32)
    if h and w and library().snc_chamfer5_labels(src, h, w, dist, labels):
        raise MemoryError("chamfer_labels: out of memory")
    return dist, labels


def remap_bilinear(field, fx, fy, border):
    """field (H, W) float32 sampled bilinearly at (fx, fy) [cells, cell centres at
    integers] (float32, any equal shapes); `border` off the grid."""
    field = np.ascontiguousarray(field, dtype=np.float32)
    fx = np.ascontiguousarray(fx, dtype=np.float32)
    fy = np.ascontiguousarray(fy, dtype=np.float32)
    if fx.shape != fy.shape:
        raise ValueError(f"remap_bilinear: map shapes differ, {fx.shape} and {fy.shape}")
    out = np.empty(fx.shape, np.float32)
    h, w = field.shape
    library().snc_remap_bilinear(field, h, w, fx.ravel(), fy.ravel(), fx.size, float(border), out.ravel())
    return out


def upsample_linear(grid, k):
    """grid (H, W) float32 resized bilinearly to (H k, W k), k a positive integer."""
    grid = np.ascontiguousarray(grid, dtype=np.float32)
    k = int(k)
    if k < 1:
        raise ValueError(f"upsample_linear: factor must be >= 1, got {k}")
    h, w = grid.shape
    out = np.empty((h * k, w * k), np.float32)
    tmp = np.empty(2 * w * k, np.float32)
    if h and w:
        library().snc_upsample_linear(grid, h, w, k, out, tmp)
    return out


def _extreme3(grid, pick, fill):
    g = np.asarray(grid)
    h, w = g.shape
    pad = np.pad(g, 1, constant_values=fill)
    out = pad[1:h + 1, 1:w + 1].copy()
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            pick(out, pad[dy:dy + h, dx:dx + w], out=out)
    return out


def _limits(dtype):
    if np.issubdtype(dtype, np.integer) or dtype == np.bool_:
        info = np.iinfo(np.uint8 if dtype == np.bool_ else dtype)
        return info.min, info.max
    return -np.inf, np.inf


def dilate3(grid):
    """Maximum over each cell's 3x3 neighbourhood (cells off the grid ignored)."""
    lo, _ = _limits(np.asarray(grid).dtype)
    return _extreme3(grid, np.maximum, lo)


def erode3(grid):
    """Minimum over each cell's 3x3 neighbourhood (cells off the grid ignored)."""
    _, hi = _limits(np.asarray(grid).dtype)
    return _extreme3(grid, np.minimum, hi)


def components8(mask):
    """(H, W) int32 labels of the 8-connected components of mask's nonzero cells (1, 2,
    ... in the raster order of each component's first cell; 0 where mask is 0)."""
    mask = _u8(mask)
    h, w = mask.shape
    labels = np.zeros((h, w), np.int32)
    if h and w and library().snc_label8(mask, h, w, labels) < 0:
        raise MemoryError("components8: out of memory")
    return labels


def fill_rays(grid, x0, y0, x1, y1, supersample, value):
    """Set to `value`, in place, every cell of the C-contiguous uint8 (H, W) `grid` under the
    rays from grid point (x0, y0) to the points (x1, y1) [cells; cell (i, j) covers
    [i, i+1) x [j, j+1)], sampled at k / n of each ray, k = 0..n, n = max(1,
    ceil(supersample x the ray's longer extent)); samples off the grid are skipped."""
    if grid.dtype != np.uint8 or not grid.flags.c_contiguous or grid.ndim != 2:
        raise ValueError("fill_rays: the grid must be a C-contiguous 2-D uint8 array")
    x1 = np.ascontiguousarray(x1, dtype=np.float64).ravel()
    y1 = np.ascontiguousarray(y1, dtype=np.float64).ravel()
    if x1.shape != y1.shape:
        raise ValueError(f"fill_rays: {x1.size} x ends but {y1.size} y ends")
    h, w = grid.shape
    library().snc_fill_rays(grid, w, h, float(x0), float(y0), x1, y1, x1.size, float(supersample), int(value))
