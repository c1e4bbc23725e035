"""Euclidean distance fields on occupancy grids: the map side of ray marching
(summit_nav_common.raycast) and of amcl's likelihood field.

Kept apart from raycast so that amcl with its default likelihood field loads neither
numba nor OpenCV (each ~60-100 MB of a node's memory). The full field is SciPy's, imported
at its first use; amcl's field, capped at laser_likelihood_max_dist, is
`bounded_distance_field`, plain numpy, so that amcl does not load SciPy (~11 MB) either.
Both run once per map.

Units: cells, in the grid's (row, column) layout.
"""
import numpy as np


def distance_field(occupied):
    """Distance [cells] from each cell centre to the nearest occupied cell centre.

    Occupied cells get 0; a grid with no occupied (or no free) cell gets the sum of its
    sides for every free cell. SciPy's exact Euclidean distance transform (Maurer et al.
    2003).
    """
    free = ~np.asarray(occupied, dtype=bool)
    if not free.any() or free.all():
        big = float(sum(free.shape))
        return np.where(free, np.float32(big), np.float32(0.0)).astype(np.float32)
    from scipy import ndimage   # at first use: a node that never calls this does not load SciPy
    return ndimage.distance_transform_edt(free).astype(np.float32)


def bounded_distance_field(occupied, limit):
    """Distance [cells] (float32) to the nearest occupied cell centre, exact up to `limit`.

    Where the distance is <= limit [cells] the value equals distance_field's (the square
    root of the same integer squared distance); elsewhere it is some value > limit. For
    fields that are capped anyway (amcl's likelihood field), at numpy's speed and without
    SciPy.

    Separable exact transform (Felzenszwalb & Huttenlocher 2012, "Distance Transforms of
    Sampled Functions", sec. 2): per column the distance to the nearest occupied cell g
    (two cumulative scans), then per row the minimum over columns x' of g(x')^2 +
    (x - x')^2, taken only over |x - x'| <= limit: a nearest cell within the limit lies
    inside that window, and g is clipped at limit + 1 (any clipped candidate already
    exceeds the limit). Cost O(H W limit).
    """
    occ = np.asarray(occupied, dtype=bool)
    h, w = occ.shape
    reach = int(np.ceil(limit))
    far = reach + 1                    # stands for "more than limit away" [cells]
    rows = np.arange(h, dtype=np.int32)[:, None]
    above = np.where(occ, rows, np.int32(-2 * far))    # nearest occupied row at or above
    np.maximum.accumulate(above, axis=0, out=above)
    below = np.where(occ, rows, np.int32(h + 2 * far))  # ... at or below
    below = np.minimum.accumulate(below[::-1], axis=0)[::-1]
    g = np.minimum(rows - above, below - rows)
    np.minimum(g, far, out=g)
    g2 = g * g
    d2 = g2.copy()
    for dx in range(1, min(reach, w - 1) + 1):
        np.minimum(d2[:, dx:], g2[:, :-dx] + dx * dx, out=d2[:, dx:])   # from the left
        np.minimum(d2[:, :-dx], g2[:, dx:] + dx * dx, out=d2[:, :-dx])  # from the right
    return np.sqrt(d2.astype(np.float64)).astype(np.float32)
