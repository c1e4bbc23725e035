"""Mixed-pixel (shadow) removal: the vectorized mask equals the per-beam oracle; a wall
keeps its points, the point floating between an edge and the background goes; the karto
core with the filter draws no dot where the floating point fell, and still matches it."""
import math

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from my_summit_mapping.shadow_filter import shadow_mask, shadow_mask_reference

ANGLES = np.linspace(-0.75 * math.pi, 0.75 * math.pi, 541)
TEN_DEG = math.radians(10.0)


@pytest.mark.parametrize("seed,window,min_angle", [(0, 1, TEN_DEG), (1, 2, math.radians(5)), (2, 3, math.radians(20))])
def test_mask_equals_the_reference(seed, window, min_angle):
    rng = np.random.default_rng(seed)
    # a smooth room-like profile with jumps, no-returns and noise
    r = 3.0 + np.sin(3 * ANGLES) + np.repeat(rng.uniform(-1.0, 1.0, 27), 21)[:len(ANGLES)]
    r += rng.normal(0, 0.01, len(r))
    r[rng.random(len(r)) < 0.03] = np.inf
    r[5] = np.nan
    assert_array_equal(shadow_mask(r, ANGLES, min_angle, window), shadow_mask_reference(r, ANGLES, min_angle, window))


def _wall_ranges(angles, distance):
    """Ranges to the line x = distance (inf where the beam does not reach it)."""
    with np.errstate(divide="ignore"):
        r = distance / np.cos(angles)
    return np.where(np.cos(angles) > 1e-9, r, np.inf)


def test_a_wall_keeps_its_points_the_floating_point_goes():
    """A door jamb 2 m away in front of a wall 6 m away: the beam on the edge reports a
    range between them (4 m). That beam and its two neighbours go, nothing else does;
    the wall beyond +-80 deg of incidence is no longer seen (within 10 deg of grazing)."""
    a = np.radians(np.arange(-60.0, 60.01, 0.25))
    r = _wall_ranges(a, 6.0)
    jamb = a > math.radians(5.0)
    r[jamb] = _wall_ranges(a[jamb], 2.0)
    edge = int(np.argmax(jamb))
    r[edge] = 4.0            # mixed: neither 2 m nor 6 m
    flagged = np.flatnonzero(shadow_mask(r, a, TEN_DEG))
    assert set(flagged) == {edge - 1, edge, edge + 1}
    assert not shadow_mask(r, a, 0.0).any()          # off


def test_karto_core_draws_no_dot_where_the_mixed_pixel_fell():
    """A robot standing before the jamb: unfiltered, the floating point's cell (passed by
    few beams) is occupied in the map; filtered it is not, and the walls are. Matching
    keeps the point either way (the node's reference)."""
    from my_summit_mapping.karto.mapper import KartoMapper, KartoParams, LaserGeometry
    a = np.radians(np.arange(-60.0, 60.01, 0.25))
    laser = LaserGeometry(angle_min=float(a[0]), angle_increment=float(a[1] - a[0]), n_beams=len(a),
                          range_min=0.1, range_max=30.0, mount=(0.0, 0.0, 0.0))
    base = _wall_ranges(a, 6.0)
    jamb = a > math.radians(5.0)
    base[jamb] = _wall_ranges(a[jamb], 2.0)
    edge = int(np.argmax(jamb))

    def occupied_at(params, point):
        mapper = KartoMapper(KartoParams.from_params(params)[0], laser)
        for k in range(6):      # standing still: a node every scan (minimum_time_interval 0)
            r = base.copy()
            r[edge] = 4.0                 # the mixed range
            mapper.add_scan(r, (0.0, 0.0, 0.0), float(k))
        grid, origin = mapper.occupancy_grid()
        res = mapper.params.resolution
        col, row = int((point[0] - origin[0]) / res), int((point[1] - origin[1]) / res)
        wall = (int((6.0 - origin[0]) / res), int((0.0 - origin[1]) / res))
        assert len(mapper.graph.nodes[0].reference) == np.isfinite(base).sum()
        return bool(grid[row, col] == 100), bool(grid[wall[1], wall[0]] == 100)

    p = 4.0 * np.array([math.cos(a[edge]), math.sin(a[edge])])   # the floating point
    dot, wall = occupied_at({"minimum_time_interval": 0.0}, p)
    assert dot and wall
    dot, wall = occupied_at({"minimum_time_interval": 0.0, "shadow_filter_min_angle": TEN_DEG}, p)
    assert not dot and wall
