"""Euclidean distance fields on occupancy grids: the map side of ray marching
(summit_nav_common.raycast) and of amcl's likelihood field.

Kept apart from raycast, and on SciPy rather than OpenCV, so that amcl with its default
likelihood field loads neither numba nor OpenCV (each ~60-100 MB of a node's memory);
it runs once per map.

Units: cells, in the grid's (row, column) layout.
"""
import numpy as np
from scipy import ndimage


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
    return ndimage.distance_transform_edt(free).astype(np.float32)
