"""Laser models: the vectorized likelihood field and beam model against the slow oracles,
amcl's beam subsampling and range preparation, and the distance field."""
import dataclasses
import math
import os

import numpy as np
import pytest

from summit_nav_common.map_io import GridMap, load_map
from summit_xl_sim.world import World

from my_summit_localization.amcl_config import AmclConfig
from my_summit_localization.likelihood_field import (
    BeamModel, LikelihoodFieldModel, beam_model_reference, likelihood_field_reference,
    obstacle_distance_field, prepare_ranges, scan_limits, select_beams)

WORLDS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "summit_xl_sim", "worlds")
BUILTIN = os.path.join(WORLDS, "course_building.yaml")
ANGLES = np.linspace(-2.356194490192345, 2.356194490192345, 1081)
MOUNT = (0.25, 0.0)


@pytest.fixture(scope="module")
def world():
    return World.from_yaml(BUILTIN)


def scan_and_particles(world, rng, n=60, beams=60):
    x, y, yaw = 6.0, 7.0, 0.4
    ranges = world.cast(x + 0.25 * math.cos(yaw), y + 0.25 * math.sin(yaw), ANGLES + yaw, 30.0)
    ranges[ranges >= 30.0] = np.inf
    use = select_beams(ranges.size, beams)
    r = prepare_ranges(ranges[use], 0.1, 30.0)
    # Particles near the truth, elsewhere on the map, and some off the map.
    p = np.column_stack([rng.uniform(-3.0, 24.0, n), rng.uniform(-3.0, 17.0, n),
                         rng.uniform(-math.pi, math.pi, n)])
    p[: n // 3] = [x, y, yaw] + rng.normal(0, [0.2, 0.2, 0.05], (n // 3, 3))
    return p, r, ANGLES[use]


def test_select_beams_is_amcls_step():
    np.testing.assert_array_equal(select_beams(1081, 60), np.arange(0, 1081, 18))
    np.testing.assert_array_equal(select_beams(10, 30), np.arange(10))
    assert select_beams(0, 30).size == 0


def test_prepare_ranges_and_limits():
    r = prepare_ranges([0.05, 1.0, np.inf, np.nan, 40.0], 0.1, 30.0)
    np.testing.assert_array_equal(r[[0, 1, 2, 4]], [30.0, 1.0, 30.0, 30.0])
    assert np.isnan(r[3])
    assert scan_limits(0.1, 30.0) == (0.1, 30.0)
    assert scan_limits(0.1, 30.0, 0.5, 12.0) == (0.5, 12.0)
    assert scan_limits(0.1, 30.0, 0.05, 40.0) == (0.1, 30.0)


def test_distance_field_cap_and_values():
    data = np.zeros((5, 7), np.int8)
    data[2, 3] = 100
    data[0, 0] = -1
    d = obstacle_distance_field(data, 0.5, 1.2)
    assert d[2, 3] == 0.0
    assert d[2, 4] == pytest.approx(0.5)
    assert d[3, 4] == pytest.approx(0.5 * math.sqrt(2), rel=1e-4)
    assert d.max() == pytest.approx(1.2)
    np.testing.assert_array_equal(obstacle_distance_field(np.zeros((3, 3), np.int8), 0.05, 2.0), 2.0)


@pytest.mark.parametrize("model_type", ["likelihood_field", "likelihood_field_prob"])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_likelihood_field_matches_reference(world, model_type, dtype):
    cfg = AmclConfig(laser_model_type=model_type, laser_sigma_hit=0.1, laser_z_hit=0.9, laser_z_rand=0.1)
    rng = np.random.default_rng(0)
    p, r, b = scan_and_particles(world, rng)
    fast = LikelihoodFieldModel(world.grid, cfg, dtype=dtype).weights(p, r, b, MOUNT, 30.0)
    ref = likelihood_field_reference(world.grid, AmclConfig(laser_sigma_hit=0.1, laser_z_hit=0.9,
                                                            laser_z_rand=0.1), p, r, b, MOUNT, 30.0)
    if model_type == "likelihood_field":
        np.testing.assert_allclose(fast, ref, rtol=1e-5)
    else:
        # the prob model is a product: check it against the same per-beam values
        assert np.all(fast > 0)
        assert np.argmax(fast) == np.argmax(ref) or np.isclose(ref[np.argmax(fast)], ref.max(), rtol=0.05)
    # the truth-near particles score above the far ones
    assert np.median(fast[:20]) > np.median(fast[20:])


def test_likelihood_field_prob_is_product_of_beams(world):
    cfg = AmclConfig(laser_model_type="likelihood_field_prob")
    model = LikelihoodFieldModel(world.grid, cfg, dtype=np.float64)
    rng = np.random.default_rng(1)
    p, r, b = scan_and_particles(world, rng, n=10, beams=8)
    got = model.weights(p, r, b, MOUNT, 30.0)
    # one beam at a time with the plain model gives 1 + pz^3 -> pz; product over beams
    plain = AmclConfig()
    per_beam = np.stack([likelihood_field_reference(world.grid, plain, p, r[k:k + 1], b[k:k + 1],
                                                    MOUNT, 30.0) for k in range(r.size)], axis=1)
    pz = np.cbrt(per_beam - 1.0)
    expected = np.prod(np.where(r < 30.0, pz, 1.0), axis=1)
    np.testing.assert_allclose(got * math.exp(model.last_log_offset), expected, rtol=1e-5)
    assert got.max() == pytest.approx(1.0)   # scaled so the best particle has 1


def test_likelihood_field_prob_many_beams_do_not_underflow(world):
    cfg = AmclConfig(laser_model_type="likelihood_field_prob", laser_max_beams=1081)
    model = LikelihoodFieldModel(world.grid, cfg)
    rng = np.random.default_rng(4)
    p, r, b = scan_and_particles(world, rng, n=30, beams=1081)
    got = model.weights(p, r, b, MOUNT, 30.0)
    assert np.all(np.isfinite(got)) and got.max() == pytest.approx(1.0)
    assert model.last_log_offset < -50      # the raw product is tiny (~1e-43 at best)
    assert np.argmax(got) < 20               # a near-truth particle is the best
    q = model.per_beam_likelihood(float(got.mean()), model.last_beams)
    assert 0.0 < q < 1.0


def test_beam_skipping_per_beam_likelihood_is_over_the_scored_beams(world):
    """With beam skipping the per-beam likelihood is the geometric mean pz of the beams
    scored, not of all beams. It used to divide by every beam: a skipped beam counted as
    pz = 1, so the scan likelihood rose and fell with the number skipped. Augmented MCL
    read such a fall as a worse scan and injected random particles (amcl_bad_input.test
    after an initialpose 0.6 m off, 46 then 48 beams scored: cov_xx 0.0004 -> 0.37)."""
    cfg = AmclConfig(laser_model_type="likelihood_field_prob", do_beamskip=True,
                     beam_skip_converged_only=True, beam_skip_error_threshold=0.5)
    model = LikelihoodFieldModel(world.grid, cfg, dtype=np.float64)
    p, r, b = scan_and_particles(world, np.random.default_rng(5), n=3, beams=8)
    p = p[:1].copy()
    p[0] = (6.0, 7.0, 0.4)                  # one particle at the truth: converged
    r = r.copy()
    r[[1, 4]] = 0.4                         # two beams hit something the map lacks
    got = model.weights(p, r, b, MOUNT, 30.0)
    kept = ~np.isin(np.arange(r.size), [1, 4])
    assert model.last_beams == int(kept.sum())
    q = model.per_beam_likelihood(float(got[0]), model.last_beams)
    # the same particle scored on the kept beams alone, with no skipping
    alone = LikelihoodFieldModel(world.grid, dataclasses.replace(cfg, do_beamskip=False), dtype=np.float64)
    got_alone = alone.weights(p, r[kept], b[kept], MOUNT, 30.0)
    assert q == pytest.approx(alone.per_beam_likelihood(float(got_alone[0]), alone.last_beams), rel=1e-9)
    assert q == pytest.approx(math.exp(alone.last_log_offset / kept.sum()), rel=1e-9)


def test_rotated_map_origin_matches_reference(world):
    grid = world.grid
    rotated = GridMap(data=grid.data, resolution=grid.resolution, origin=(3.0, -2.0, 0.7))
    cfg = AmclConfig()
    rng = np.random.default_rng(2)
    p, r, b = scan_and_particles(world, rng)
    fast = LikelihoodFieldModel(rotated, cfg, dtype=np.float64).weights(p, r, b, MOUNT, 30.0)
    ref = likelihood_field_reference(rotated, cfg, p, r, b, MOUNT, 30.0)
    np.testing.assert_allclose(fast, ref, rtol=1e-6)


def test_max_range_and_nan_beams_are_skipped(world):
    cfg = AmclConfig()
    model = LikelihoodFieldModel(world.grid, cfg)
    p = np.array([[6.0, 7.0, 0.0]])
    out = model.weights(p, np.array([30.0, np.nan]), np.array([0.0, 0.1]), MOUNT, 30.0)
    assert out[0] == 1.0  # no usable beam: amcl's p starts at 1 and stays


def test_off_map_end_point_uses_max_dist():
    data = np.zeros((10, 10), np.int8)
    data[5, 5] = 100
    grid = GridMap(data=data, resolution=0.1, origin=(0.0, 0.0, 0.0))
    cfg = AmclConfig(laser_likelihood_max_dist=0.3)
    model = LikelihoodFieldModel(grid, cfg, dtype=np.float64)
    p = np.array([[0.5, 0.5, 0.0], [-50.0, -50.0, 0.0]])
    got = model.weights(p, np.array([5.0]), np.array([0.0]), (0.0, 0.0), 10.0)
    pz_far = cfg.laser_z_hit * math.exp(-0.09 / (2 * 0.2 ** 2)) + cfg.laser_z_rand / 10.0
    np.testing.assert_allclose(got, 1.0 + pz_far ** 3)


def test_beam_model_matches_reference(world):
    cfg = AmclConfig(laser_model_type="beam")
    rng = np.random.default_rng(3)
    p, r, b = scan_and_particles(world, rng, n=12, beams=12)
    fast = BeamModel(world.grid, cfg).weights(p, r, b, MOUNT, 30.0)
    ref = beam_model_reference(world.grid, cfg, p, r, b, MOUNT, 30.0)
    np.testing.assert_allclose(fast, ref, rtol=1e-9)
    assert np.argmax(fast) < 4  # a truth-near particle scores best


def test_willow_map_loads_and_scores():
    path = os.path.join(os.path.dirname(__file__), "..", "..", "..", "data", "maps",
                        "willow-full-0.05.yaml")  # the workspace's data/
    grid = load_map(path)
    model = LikelihoodFieldModel(grid, AmclConfig())
    out = model.weights(np.array([[10.0, 10.0, 0.0]]), np.array([1.0, 2.0]), np.array([0.0, 1.0]),
                        MOUNT, 30.0)
    assert 1.0 <= out[0] <= 3.0
