"""amcl's sample motion models: sample mean and spread against the analytic values."""
import math

import numpy as np
import pytest

from my_summit_localization import motion_model as mm

N = 200_000   # samples per check
ALPHAS = (0.02, 0.03, 0.05, 0.04, 0.06)


def moved(model, delta, old_yaw=0.3, start=(1.0, 2.0, 0.3), alphas=ALPHAS, seed=0):
    particles = np.tile(np.asarray(start, float), (N, 1))
    out = mm.sample_motion(model, particles, np.asarray(delta), old_yaw, alphas,
                           np.random.default_rng(seed))
    return particles, out


@pytest.mark.parametrize("corrected", [False, True])
def test_diff_straight_move(corrected):
    """Pure forward motion: rot1 = rot2 = 0, so the distance moved is trans^ exactly and
    the heading change is rot1^ + rot2^."""
    yaw0, trans = 0.3, 0.4
    delta = (trans * math.cos(yaw0), trans * math.sin(yaw0), 0.0)
    model = "diff-corrected" if corrected else "diff"
    start, out = moved(model, delta, old_yaw=yaw0)
    a1, a2, a3, a4, _ = ALPHAS
    sd_rot = a2 * trans ** 2
    sd_trans = a3 * trans ** 2
    if corrected:
        sd_rot, sd_trans = math.sqrt(sd_rot), math.sqrt(sd_trans)
    d = out[:, :2] - start[:, :2]
    dist = np.hypot(d[:, 0], d[:, 1])
    heading = np.arctan2(d[:, 1], d[:, 0]) - yaw0       # = -n_rot1
    dyaw = mm.wrap_angle(out[:, 2] - yaw0)               # = -n_rot1 - n_rot2
    tol = 4.0 / math.sqrt(N)  # ~4 standard errors, relative
    np.testing.assert_allclose(dist.mean(), trans, atol=4 * sd_trans / math.sqrt(N) + 1e-12)
    np.testing.assert_allclose(dist.std(), sd_trans, rtol=tol * 2)
    np.testing.assert_allclose(heading.mean(), 0.0, atol=4 * sd_rot / math.sqrt(N))
    np.testing.assert_allclose(heading.std(), sd_rot, rtol=tol * 2)
    np.testing.assert_allclose(dyaw.std(), math.sqrt(2) * sd_rot, rtol=tol * 2)


def test_diff_rotate_in_place_and_turn():
    """In place (< 1 cm): rot1 = 0, rot2 = dyaw; the position stays put on average."""
    dyaw = 0.8
    start, out = moved("diff", (0.0, 0.0, dyaw))
    a1, a2, a3, a4, _ = ALPHAS
    sd_rot2 = a1 * dyaw ** 2
    sd_trans = a4 * dyaw ** 2          # from r2n (r1n = 0)
    dy = mm.wrap_angle(out[:, 2] - start[:, 2])
    np.testing.assert_allclose(dy.mean(), dyaw, atol=4 * sd_rot2 / math.sqrt(N))
    np.testing.assert_allclose(dy.std(), sd_rot2, rtol=0.02)
    d = np.hypot(*(out[:, :2] - start[:, :2]).T)
    # trans^ = -N(sd_trans): |trans^| is half-normal, mean sd * sqrt(2/pi)
    np.testing.assert_allclose(d.mean(), sd_trans * math.sqrt(2 / math.pi), rtol=0.02)


def test_diff_noise_terms_match_amcl_formulas():
    """rot1 from the odom-frame bearing, backward folding, amcl's std expressions."""
    a = ALPHAS
    (rot1, trans, rot2), sd = mm.diff_noise_std((-0.3, 0.0, 0.1), old_yaw=0.0, alphas=a)
    assert rot1 == pytest.approx(math.pi) or rot1 == pytest.approx(-math.pi)
    assert trans == pytest.approx(0.3)
    assert rot2 == pytest.approx(float(mm.angle_diff(0.1, rot1)))
    r1n, r2n = 0.0, abs(0.1)  # backward move: rot1 folds to 0; rot2 = 0.1 - pi folds to 0.1
    np.testing.assert_allclose(sd, [a[0] * r1n ** 2 + a[1] * 0.09,
                                    a[2] * 0.09 + a[3] * r1n ** 2 + a[3] * r2n ** 2,
                                    a[0] * r2n ** 2 + a[1] * 0.09], atol=1e-12)
    _, sdc = mm.diff_noise_std((-0.3, 0.0, 0.1), old_yaw=0.0, alphas=a, corrected=True)
    np.testing.assert_allclose(sdc, np.sqrt(sd))


@pytest.mark.parametrize("corrected", [False, True])
def test_omni_components(corrected):
    """Omni: along the odometry bearing trans^ (mean trans), across it -strafe^ (mean 0),
    yaw change rot^ (mean dyaw), each with amcl's std."""
    yaw0 = 0.3
    delta = (0.2, 0.3, 0.25)   # a sideways-ish move with a turn, odom frame
    model = "omni-corrected" if corrected else "omni"
    start, out = moved(model, delta, old_yaw=yaw0, start=(0.0, 0.0, yaw0))
    a1, a2, a3, a4, a5 = ALPHAS
    trans, rot = math.hypot(0.2, 0.3), 0.25
    sd = np.array([a3 * trans ** 2 + a1 * rot ** 2, a4 * rot ** 2 + a2 * trans ** 2,
                   a1 * rot ** 2 + a5 * trans ** 2])
    if corrected:
        sd = np.sqrt(sd)
    bearing = math.atan2(0.3, 0.2)  # old particle yaw equals old odom yaw here
    d = out[:, :2] - start[:, :2]
    along = d[:, 0] * math.cos(bearing) + d[:, 1] * math.sin(bearing)
    across = -d[:, 0] * math.sin(bearing) + d[:, 1] * math.cos(bearing)
    dyaw = mm.wrap_angle(out[:, 2] - yaw0)
    se = 4.0 / math.sqrt(N)
    np.testing.assert_allclose(along.mean(), trans, atol=se * sd[0] + 1e-12)
    np.testing.assert_allclose(along.std(), sd[0], rtol=0.02)
    np.testing.assert_allclose(across.mean(), 0.0, atol=se * sd[2] + 1e-12)
    np.testing.assert_allclose(across.std(), sd[2], rtol=0.02)
    np.testing.assert_allclose(dyaw.mean(), rot, atol=se * sd[1] + 1e-12)
    np.testing.assert_allclose(dyaw.std(), sd[1], rtol=0.02)


def test_in_place_buffers_and_seeding():
    p = np.tile([1.0, 2.0, 3.0], (100, 1))
    noise = np.empty((100, 3))
    a = mm.sample_motion("diff", p.copy(), (0.1, 0.0, 0.1), 0.0, ALPHAS, np.random.default_rng(5))
    q = p.copy()
    out = mm.sample_motion("diff", q, (0.1, 0.0, 0.1), 0.0, ALPHAS, np.random.default_rng(5),
                           noise=noise, out=q)
    assert out is q
    np.testing.assert_array_equal(a, q)
    assert np.all((q[:, 2] >= -math.pi) & (q[:, 2] < math.pi))


def test_zero_alphas_is_exact_odometry():
    start, out = moved("diff", (0.3, 0.1, 0.2), old_yaw=0.0, start=(0.0, 0.0, 0.0), alphas=(0.0,) * 5)
    np.testing.assert_allclose(out[0], [0.3, 0.1, 0.2], atol=1e-12)


def test_unknown_model():
    with pytest.raises(ValueError, match="odom_model_type"):
        mm.sample_motion("ackermann", np.zeros((2, 3)), (0, 0, 0), 0.0, ALPHAS, np.random.default_rng(0))
