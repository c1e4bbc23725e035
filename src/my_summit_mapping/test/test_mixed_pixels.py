"""Mixed pixels: the vectorized mask equals the per-beam oracle; the point floating
between an edge and the background goes, and nothing else does (not the edge's own
beams, not a pole one beam wide, not a wall seen at grazing); on the simulator's UTM-30LX
the test finds the mixed pixels it made; the karto core with the filter draws no dot
where the floating point fell, and still matches it."""
import math

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from my_summit_mapping.mixed_pixels import mixed_pixel_mask, mixed_pixel_mask_reference

ANGLES = np.linspace(-0.75 * math.pi, 0.75 * math.pi, 541)
OFFSET = 0.1


@pytest.mark.parametrize("seed,offset", [(0, 0.05), (1, 0.1), (2, 0.2)])
def test_mask_equals_the_reference(seed, offset):
    rng = np.random.default_rng(seed)
    # a smooth room-like profile with jumps, mixed ranges, no-returns and noise
    r = 3.0 + np.sin(3 * ANGLES) + np.repeat(rng.uniform(-1.0, 1.0, 27), 21)[:len(ANGLES)]
    jumps = np.flatnonzero(np.abs(np.diff(r)) > 0.2)
    r[jumps] = r[jumps] + rng.uniform(0.1, 0.9, len(jumps)) * (r[jumps + 1] - r[jumps])
    r += rng.normal(0, 0.01, len(r))
    r[rng.random(len(r)) < 0.03] = np.inf
    r[5] = np.nan
    got = mixed_pixel_mask(r, ANGLES, offset)
    assert_array_equal(got, mixed_pixel_mask_reference(r, ANGLES, offset))
    assert 0 < got.sum() <= len(jumps)
    assert not mixed_pixel_mask(r, ANGLES, 0.0).any()          # off


def _wall_ranges(angles, distance):
    """Ranges to the line x = distance (inf where the beam does not reach it)."""
    with np.errstate(divide="ignore"):
        r = distance / np.cos(angles)
    return np.where(np.cos(angles) > 1e-9, r, np.inf)


def test_only_the_floating_point_goes():
    """A door jamb 2 m away in front of a wall 6 m away, seen from -88 to 88 deg (the
    wall seen at up to 88 deg of incidence, 0.25 deg a beam: its ranges grow by up to
    0.9 m a beam), a pole one beam wide before the wall, and noise: the beam on the
    jamb's edge reports 4 m, neither 2 m nor 6 m. That beam goes, nothing else does."""
    rng = np.random.default_rng(3)
    a = np.radians(np.arange(-88.0, 88.01, 0.25))
    r = _wall_ranges(a, 6.0)
    jamb = a > math.radians(5.0)
    r[jamb] = _wall_ranges(a[jamb], 2.0)
    edge = int(np.argmax(jamb))
    pole = int(np.argmin(np.abs(a + math.radians(30.0))))
    r[pole] = 3.0
    r += rng.normal(0.0, 0.01, len(r))
    r[edge] = 4.0            # mixed
    assert list(np.flatnonzero(mixed_pixel_mask(r, a, OFFSET))) == [edge]
    assert_array_equal(mixed_pixel_mask(r, a, OFFSET), mixed_pixel_mask_reference(r, a, OFFSET))


def test_the_simulated_utm30lx_mixed_pixels_are_found():
    """The simulator's laser model over a scene of edges: of the beams it reported more
    than 0.1 m off both surfaces of their edge, the test finds >= 90 %; of the beams it
    reported on a surface, it flags < 0.5 %."""
    from summit_xl_sim.laser_model import Utm30lxLaser
    rng = np.random.default_rng(7)
    laser = Utm30lxLaser()
    a = np.linspace(-0.75 * math.pi, 0.75 * math.pi, 1081)
    inc = a[1] - a[0]
    # walls at 6 m and boxes 1.5-4 m away, 5-40 beams wide, each with its own slant
    exact = _wall_ranges(a - 0.3, 6.0)
    exact[~np.isfinite(exact)] = 25.0
    k = 0
    while k < len(a) - 50:
        w = int(rng.integers(5, 40))
        exact[k:k + w] = _wall_ranges(a[k:k + w] - rng.uniform(-1.2, 1.2), rng.uniform(1.5, 4.0))
        k += w + int(rng.integers(5, 40))
    exact = np.minimum(exact, 25.0)
    found = floating = wrong = surface = 0
    for _ in range(40):
        r = laser.measure(exact, np.ones_like(exact), inc, 0.1, 30.0, rng).astype(float)
        noisy_exact = exact  # what each beam would read without the mixing
        ok = np.isfinite(r)
        off = ok & (np.abs(r - noisy_exact) > 0.1)
        # a beam is floating when it is off its own surface and off the neighbours' too
        nb = np.minimum(np.abs(r - np.roll(exact, 1)), np.abs(r - np.roll(exact, -1)))
        float_mask = off & (nb > 0.1)
        mask = mixed_pixel_mask(r, a, OFFSET)
        found += (mask & float_mask).sum()
        floating += float_mask.sum()
        on_surface = ok & (np.abs(r - noisy_exact) < 0.05)
        wrong += (mask & on_surface).sum()
        surface += on_surface.sum()
    assert floating > 100
    assert found / floating >= 0.9, (found, floating)
    assert wrong / surface < 0.005, (wrong, surface)


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
    dot, wall = occupied_at({"minimum_time_interval": 0.0, "mixed_pixel_min_offset": OFFSET}, p)
    assert not dot and wall
