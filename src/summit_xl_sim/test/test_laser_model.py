"""Laser range models: utm30lx noise by band, mixed pixels, grazing dropouts; ideal unchanged."""
import math
import os

import numpy as np
import pytest

from summit_nav_common.testing import scenes
from summit_xl_sim.laser_model import IdealLaser, Utm30lxLaser, make_laser_model
from summit_xl_sim.sim import LaserParams, Simulation
from summit_xl_sim.world import World, WorldError

HERE = os.path.dirname(os.path.abspath(__file__))
BUILTIN = os.path.join(HERE, "..", "worlds", "course_building.yaml")
LASER = LaserParams()
STEP = LASER.angle_increment


def empty_room(size_m=20.0, resolution=0.05):
    """The simulator's world of scenes.square_room: no depth edge anywhere."""
    return World(scenes.square_room(size_m, resolution))


def scans(sim, name, count):
    return np.array([sim.scan(name) for _ in range(count)])


@pytest.mark.parametrize("true_range, sigma", [(1.0, 0.010), (5.0, 0.010), (9.9, 0.010),
                                               (10.1, 0.050 / 3), (20.0, 0.050 / 3), (29.0, 0.050 / 3)])
def test_utm30lx_noise_by_range_band(true_range, sigma):
    """The datasheet's +-30 mm (to 10 m) and +-50 mm (10-30 m) read as 3 sigma: the noise
    on a flat target at normal incidence has that sigma and no bias."""
    model = Utm30lxLaser()
    rng = np.random.default_rng(11)
    ranges = np.full(LASER.n_beams, true_range)
    cos_inc = np.ones(LASER.n_beams)
    d = np.concatenate([model.measure(ranges, cos_inc, STEP, 0.1, 30.0, rng) - true_range
                        for _ in range(20)])
    assert np.isfinite(d).all()  # no dropouts at normal incidence, no mixed pixels on a flat target
    # 21620 samples: the sample sigma is within ~0.5 % of the true one (1 s.e.)
    assert d.std() == pytest.approx(sigma, rel=0.03)
    assert abs(d.mean()) < 4 * sigma / math.sqrt(d.size)


def test_utm30lx_vectorized_matches_reference():
    """measure (vectorized) gives exactly the per-beam reference's ranges for the same
    draws: on a real scan of the built-in world (walls, doors) and on random ranges
    (edges everywhere, beams between two edges, no-returns, grazing beams)."""
    model = Utm30lxLaser()
    world = World.from_yaml(BUILTIN)
    world.add_box("b", 6.0, 7.4, 0.3, 0.5, 0.4)
    cases = [world.cast_hits(2.25, 7.0, LASER.angles() + 0.3, 30.0)]
    rng = np.random.default_rng(5)
    r = rng.uniform(0.2, 31.0, 2000)
    r[rng.random(2000) < 0.1] = 30.0
    cases.append((r, rng.uniform(0.0, 1.0, 2000)))
    for ranges, cos_inc in cases:
        for seed in range(3):
            fast = model.measure(ranges, cos_inc, STEP, 0.1, 30.0, np.random.default_rng(seed))
            slow = model.measure_reference(ranges, cos_inc, STEP, 0.1, 30.0, np.random.default_rng(seed))
            np.testing.assert_array_equal(fast, slow)


def test_mixed_pixels_at_a_depth_edge_and_not_on_a_flat_wall():
    """Inside an empty room (no depth edge) no finite range strays more than 6 sigma (of
    its band) from the exact one; with a box in front of the far wall, points between the box and the
    wall appear, only on the two beams around each of the box's edges, at about the
    modelled rate (an edge mixes one beam, with probability 0.5, by a fraction U(0, 0.5))."""
    world = empty_room()
    sim = Simulation(world, seed=4)
    sim.add_robot("r", 5.0, 10.0, 0.0)
    model = Utm30lxLaser()
    exact = sim.scan("r", noise=False)
    got = scans(sim, "r", 200)
    stray = np.isfinite(got) & (np.abs(got - exact) > 6 * model.sigma(exact))
    assert not stray.any()

    world.add_box("box", 8.0, 10.0, 0.0, 0.4, 1.0)  # near face at x 7.8 m; the far wall at x 19.95 m
    exact = sim.scan("r", noise=False)
    jump = np.abs(np.diff(exact.astype(np.float64)))
    edges = np.flatnonzero(jump > 1.0)
    assert len(edges) == 2
    got = scans(sim, "r", 400)
    threshold = 6 * model.sigma(exact)  # [m] 60 mm on the box, 100 mm on the far wall
    stray = np.isfinite(got) & (np.abs(got - exact) > threshold)
    near_edges = np.zeros(LASER.n_beams, bool)
    for k in edges:
        near_edges[k:k + 2] = True
    assert stray.any(axis=0)[near_edges].all() and not stray.any(axis=0)[~near_edges].any()
    for k in edges:
        near, far = sorted((exact[k], exact[k + 1]))
        pair = got[:, k:k + 2][stray[:, k:k + 2]]
        assert (pair > near).all() and (pair < far).all()  # between the two surfaces
        # Rate per scan: 0.5 x P(f * jump > threshold of the mixed beam), f ~ U(0, 0.5),
        # the mixed beam being either of the two with even odds.
        expected = 0.5 * (1.0 - threshold[k:k + 2].mean() / (0.5 * (far - near)))
        assert stray[:, k:k + 2].any(axis=1).mean() == pytest.approx(expected, abs=0.08)


def test_grazing_dropouts_at_grazing_angles_only():
    """A robot 1 m from a long wall, looking along it: the beams that hit that wall
    beyond 80 deg of incidence are lost at the modelled rate (0 at 80 deg rising to 1 at
    90 deg); beams at normal incidence (the wall ahead) and below 80 deg never are."""
    world = empty_room()
    sim = Simulation(world, seed=8)
    # Laser at (2.25, 1.05): 1.0 m above the south wall's face (y 0.05).
    sim.add_robot("r", 2.0, 1.05, 0.0)
    lx, ly, lyaw = sim.laser_pose(sim.robot("r"))
    angles = LASER.angles() + lyaw
    exact, cos_inc = world.cast_hits(lx, ly, angles, 30.0)
    incidence = np.degrees(np.arccos(cos_inc))
    south = (angles < 0) & (angles > -math.pi / 2) & (np.abs(exact * np.sin(angles) + 1.0) < 1e-6)
    # The incidence on the south wall's cell edges is 90 deg minus the depression angle.
    np.testing.assert_allclose(incidence[south], 90.0 + np.degrees(angles[south]), atol=1e-6)
    got = scans(sim, "r", 300)
    lost = np.isinf(got)
    assert not lost[:, incidence < 80.0].any()
    ahead = np.abs(angles) < math.radians(2.0)
    assert (incidence[ahead] < 3.0).all() and not lost[:, ahead].any()
    for lo, hi in ((80.0, 84.0), (84.0, 88.0)):
        band = south & (incidence >= lo) & (incidence < hi)
        assert band.sum() >= 5
        expected = Utm30lxLaser().dropout_prob(cos_inc[band]).mean()
        assert lost[:, band].mean() == pytest.approx(expected, abs=0.05)


def test_ideal_unchanged_from_before_laser_model():
    """laser_model ideal gives the very scans the simulator gave before the model existed
    (values recorded from that code: built-in world, seed 7, robot at (2, 7, 0.3),
    every 120th beam of its first three scans)."""
    before = [
        [4.584270477294922, 5.178550720214844, 3.391223430633545, 6.348996639251709, 9.670659065246582,
         9.887907981872559, 3.340071201324463, 6.816648960113525, 4.033565044403076, 2.4070892333984375],
        [4.581562519073486, 5.179751873016357, 3.398698091506958, 6.334385395050049, 9.684066772460938,
         9.88698673248291, 3.345369815826416, 6.83091402053833, 4.016396522521973, 2.4155468940734863],
        [4.581450939178467, 5.175937652587891, 3.393430471420288, 6.355015277862549, 9.68634033203125,
         9.905460357666016, 3.34515643119812, 6.8357439041137695, 4.008949279785156, 2.4004335403442383]]
    sim = Simulation(World.from_yaml(BUILTIN), seed=7)
    sim.add_robot("r", 2.0, 7.0, 0.3, laser=LaserParams(model="ideal"))
    for expected in before:
        np.testing.assert_array_equal(sim.scan("r")[::120], np.array(expected, np.float32))


def test_default_model_and_bad_names():
    assert LaserParams().model == "utm30lx"
    assert isinstance(make_laser_model("ideal", 0.02), IdealLaser)
    with pytest.raises(ValueError, match="laser_model must be one of utm30lx, ideal, got 'sick'"):
        make_laser_model("sick")
    with pytest.raises(ValueError, match="laser_noise must be a finite sigma >= 0"):
        make_laser_model("ideal", -0.01)
    sim = Simulation(empty_room(), seed=0)
    with pytest.raises(WorldError, match="robot 'r': laser_model must be one of"):
        sim.add_robot("r", 5.0, 5.0, 0.0, laser=LaserParams(model="sick"))
