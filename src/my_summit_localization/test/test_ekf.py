"""The EKF core against hand-computed prediction and correction steps, a finite-difference
Jacobian, two_d_mode, angle wrapping, Mahalanobis rejection and non-finite input."""
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_localization import ekf
from my_summit_localization.ekf import (PITCH, ROLL, STATE_SIZE, VROLL, VX, VY, VYAW, VZ, X, Y, YAW, Z, Ekf,
                                       Measurement)

Q = np.diag([0.05, 0.05, 0.06, 0.03, 0.03, 0.06, 0.025, 0.025, 0.04, 0.01, 0.01, 0.02, 0.01, 0.01, 0.015])


def meas(stamp, values, variances, threshold=math.inf):
    """A Measurement of {index: value} with {index: variance}."""
    z = np.full(STATE_SIZE, np.nan)
    cov = np.zeros((STATE_SIZE, STATE_SIZE))
    mask = np.zeros(STATE_SIZE, dtype=bool)
    for i, v in values.items():
        z[i] = v
        cov[i, i] = variances[i]
        mask[i] = True
    return Measurement(stamp, z, cov, mask, threshold, "test")


def started(two_d=False, p0=0.01, **state):
    f = Ekf(Q, np.eye(STATE_SIZE) * p0, two_d_mode=two_d)
    x = np.zeros(STATE_SIZE)
    for k, v in state.items():
        x[getattr(ekf, k.upper())] = v
    f.reset(x, np.eye(STATE_SIZE) * p0, stamp=0.0)
    return f


def test_prediction_by_hand():
    """Unicycle in the plane: x += cos(yaw) vx dt, y += sin(yaw) vx dt, yaw += vyaw dt;
    P[x, x] picks up the yaw and vx variances through the Jacobian, plus Q dt."""
    yaw, vx, vyaw, dt, p0 = 0.5, 1.0, 0.2, 0.1, 0.01
    f = started(yaw=yaw, vx=vx, vyaw=vyaw, p0=p0)
    f.predict_to(dt)
    assert f.time == dt
    assert_allclose(f.x[[X, Y, YAW, VX, VYAW]],
                    [math.cos(yaw) * vx * dt, math.sin(yaw) * vx * dt, yaw + vyaw * dt, vx, vyaw], atol=1e-12)
    # row x of the Jacobian: 1 (x), -sin(yaw) vx dt (yaw), cos(yaw) dt (vx), -sin(yaw) dt (vy),
    # cos(yaw) dt^2/2 (ax), -sin(yaw) dt^2/2 (ay); P diagonal p0
    c, s = math.cos(yaw), math.sin(yaw)
    row = [1.0, -s * vx * dt, c * dt, -s * dt, c * dt * dt / 2, -s * dt * dt / 2]
    pxx = sum(j * j for j in row) * p0 + Q[X, X] * dt
    assert f.P[X, X] == pytest.approx(pxx, rel=1e-12)
    # yaw: yaw += vyaw dt
    assert f.P[YAW, YAW] == pytest.approx(p0 + dt * dt * p0 + Q[YAW, YAW] * dt, rel=1e-12)
    # cross term x-yaw: J_x . P . J_yaw = (-sin(yaw) vx dt) * p0 * 1
    assert f.P[X, YAW] == pytest.approx(-math.sin(yaw) * vx * dt * p0, rel=1e-12)
    assert_allclose(f.P, f.P.T, atol=0)


def test_prediction_with_acceleration_by_hand():
    """x += R (v dt + a dt^2 / 2), v += a dt."""
    f = started(yaw=math.pi / 2, vx=1.0, ax=2.0)
    f.predict(0.5)
    assert_allclose(f.x[[X, Y, VX]], [0.0, 1.0 * 0.5 + 0.5 * 2.0 * 0.25, 2.0], atol=1e-12)


def test_jacobian_matches_finite_differences_in_3d():
    """The analytic Jacobian (slow oracle: central differences of predict_state)."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        x = rng.normal(0.0, 0.6, STATE_SIZE)
        dt = 0.05 + rng.random() * 0.2
        j = ekf.predict_jacobian(x, dt)
        num = np.zeros_like(j)
        h = 1e-6
        for k in range(STATE_SIZE):
            e = np.zeros(STATE_SIZE)
            e[k] = h
            d = ekf.predict_state(x + e, dt) - ekf.predict_state(x - e, dt)
            d[list(ekf.ANGLES)] = ekf.wrap(d[list(ekf.ANGLES)])
            num[:, k] = d / (2 * h)
        assert_allclose(j, num, atol=1e-7)


def test_euler_rates_from_body_rates():
    """A body roll rate with the robot pitched moves roll only; a body yaw rate with the
    robot rolled by 90 deg shows as a pitch rate (-sin(roll) vyaw)."""
    e, _, _ = ekf.euler_rate_matrix(0.0, 0.3)
    assert_allclose(e @ [1.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    e, _, _ = ekf.euler_rate_matrix(math.pi / 2, 0.0)
    assert_allclose(e @ [0.0, 0.0, 1.0], [0.0, -1.0, 0.0], atol=1e-12)


def test_correction_by_hand():
    """Scalar update of yaw: K = P / (P + R), x += K (z - x), P' = P R / (P + R) (the
    Joseph form gives the same)."""
    f = started(p0=0.04)
    out = f.process(meas(0.0, {YAW: 0.1}, {YAW: 0.01}))
    assert out.accepted and out.mahalanobis_sq == pytest.approx(0.1 ** 2 / 0.05)
    assert f.x[YAW] == pytest.approx(0.8 * 0.1)
    assert f.P[YAW, YAW] == pytest.approx(0.04 * 0.01 / 0.05)
    assert f.P[X, X] == pytest.approx(0.04)   # uncorrelated: untouched


def test_correction_through_correlation():
    """Measuring vx after a prediction corrects x through their covariance: the gain on x
    is P[x, vx] / (P[vx, vx] + R)."""
    f = started(vx=1.0, p0=0.01)
    f.predict_to(1.0)
    p = f.P.copy()
    x_before = f.x.copy()
    f.process(meas(1.0, {VX: 1.5}, {VX: 0.02}))
    k_x = p[X, VX] / (p[VX, VX] + 0.02)
    assert f.x[X] == pytest.approx(x_before[X] + k_x * 0.5)
    assert f.P[X, X] == pytest.approx(p[X, X] - p[X, VX] ** 2 / (p[VX, VX] + 0.02))


def test_angle_innovation_wraps():
    """Estimate 3.1 rad, measurement -3.1 rad: they differ by 0.083 rad across +-pi, not
    6.2 rad; the result stays in [-pi, pi)."""
    f = started(yaw=3.1, p0=0.01)
    f.process(meas(0.0, {YAW: -3.1}, {YAW: 0.01}))
    expected = ekf.wrap(3.1 + 0.5 * (2 * math.pi - 6.2))
    assert f.x[YAW] == pytest.approx(expected)
    assert -math.pi <= f.x[YAW] < math.pi


def test_outlier_rejected_by_mahalanobis_threshold():
    """Innovation 1 m with S = 0.05 m^2: distance 4.47 >= 3 rejects it, state and P kept;
    with threshold 5 it is fused."""
    f = started(p0=0.04)
    before = (f.x.copy(), f.P.copy())
    out = f.process(meas(0.0, {X: 1.0}, {X: 0.01}, threshold=3.0))
    assert not out.accepted and "Mahalanobis" in out.reason
    assert out.mahalanobis_sq == pytest.approx(20.0)
    assert_allclose(f.x, before[0])
    assert_allclose(f.P, before[1])
    assert f.process(meas(0.0, {X: 1.0}, {X: 0.01}, threshold=5.0)).accepted


def test_non_finite_values_are_never_fused():
    """A NaN value, or a NaN variance, leaves out that variable; with nothing left the
    measurement is not accepted; the state stays finite."""
    f = started(p0=0.04)
    out = f.process(meas(0.0, {X: math.nan, Y: 0.2}, {X: 0.01, Y: 0.01}))
    assert out.accepted and out.indices == (Y,)
    out = f.process(meas(0.0, {X: 1.0}, {X: math.nan}))
    assert not out.accepted
    out = f.process(meas(0.0, {X: math.inf}, {X: 0.01}))
    assert not out.accepted
    assert np.all(np.isfinite(f.x)) and np.all(np.isfinite(f.P))


def test_zero_variance_raised_to_minimum():
    """A measurement with variance 0 (a sensor that claims to be perfect) is fused with
    1e-9, not a singular innovation covariance."""
    f = started(p0=0.04)
    assert f.process(meas(0.0, {X: 0.5}, {X: 0.0})).accepted
    assert f.x[X] == pytest.approx(0.5, abs=1e-6)
    assert f.P[X, X] > 0


def test_two_d_mode_holds_3d_variables_at_zero():
    """In two_d_mode a measurement of z and roll is ignored, prediction with a pitch rate
    leaves pitch at 0, and those variances stay tiny while x, y, yaw evolve."""
    f = started(two_d=True, vx=1.0)
    f.x[VROLL] = 0.5     # set behind the filter's back: the next step clears it
    f.predict_to(0.5)
    assert_allclose(f.x[[Z, ROLL, PITCH, VZ, VROLL]], 0.0)
    assert f.x[X] == pytest.approx(0.5)
    out = f.process(meas(0.5, {Z: 3.0, ROLL: 0.4}, {Z: 0.01, ROLL: 0.01}))
    assert not out.accepted
    assert f.P[Z, Z] == ekf.TWO_D_VARIANCE and f.P[ROLL, X] == 0.0
    assert f.process(meas(0.5, {Z: 3.0, YAW: 0.4}, {Z: 0.01, YAW: 0.01})).indices == (YAW,)


def test_first_measurement_initializes():
    """Before any measurement the filter does not predict; the first sets the variables it
    measures and their variances (robot_localization's initialization)."""
    f = Ekf(Q, np.eye(STATE_SIZE) * 1e-9, two_d_mode=True)
    out = f.process(meas(5.0, {VX: 0.3, VYAW: 0.1}, {VX: 0.001, VYAW: 0.002}))
    assert out.reason == "initialized" and f.time == 5.0
    assert f.x[VX] == 0.3 and f.x[VYAW] == 0.1 and f.x[X] == 0.0
    assert f.P[VX, VX] == 0.001 and f.P[X, X] == 1e-9


def test_older_stamp_corrected_without_prediction():
    """A measurement stamped before the filter's time is fused without predicting back;
    the filter's time does not go back."""
    f = started(vx=1.0)
    f.predict_to(1.0)
    x = f.x[X]
    assert f.process(meas(0.5, {VY: 0.0}, {VY: 0.01})).accepted
    assert f.time == 1.0 and f.x[X] == pytest.approx(x)


def test_covariance_stays_symmetric_positive_definite():
    """A long random sequence of predictions and corrections keeps P symmetric with
    positive eigenvalues."""
    rng = np.random.default_rng(7)
    f = Ekf(Q, np.eye(STATE_SIZE) * 1e-9, two_d_mode=True)
    t = 0.0
    for k in range(2000):
        t += 0.01
        if k % 2:
            f.process(meas(t, {VX: rng.normal(1, 0.1), VYAW: rng.normal(0.3, 0.05)}, {VX: 1e-3, VYAW: 1e-4}))
        else:
            f.process(meas(t, {VYAW: rng.normal(0.3, 0.01)}, {VYAW: 1e-6}))
    assert_allclose(f.P, f.P.T, atol=0)
    assert np.linalg.eigvalsh(f.P).min() > 0
    assert f.x[VX] == pytest.approx(1.0, abs=0.1)


def test_fast_step_matches_the_reference():
    """predict_step (scalar arithmetic, the filter's) against predict_state and
    predict_jacobian (the obvious matrix form) on random 3D states."""
    rng = np.random.default_rng(11)
    j = np.eye(STATE_SIZE)
    for _ in range(50):
        x = rng.normal(0.0, 0.8, STATE_SIZE)
        dt = rng.uniform(0.001, 0.3)
        assert_allclose(ekf.predict_step(x, dt, j), ekf.predict_state(x, dt), atol=1e-12)
        assert_allclose(j, ekf.predict_jacobian(x, dt), atol=1e-12)


def test_fast_correction_matches_the_reference():
    """Ekf.correct (no H, P's Joseph update on the measured columns only) against
    correction_reference (H, S, K and (I - K H) P (I - K H)^T + K R K^T as written) on
    random states, covariances and subsets, angles among them."""
    rng = np.random.default_rng(5)
    for trial in range(200):
        f = Ekf(Q, np.eye(STATE_SIZE), two_d_mode=False)
        a = rng.normal(0.0, 0.3, (STATE_SIZE, STATE_SIZE))
        p = a @ a.T + 0.01 * np.eye(STATE_SIZE)
        x = rng.normal(0.0, 1.0, STATE_SIZE)
        x[3:6] = rng.uniform(-math.pi, math.pi, 3)
        f.reset(x, p, stamp=0.0)
        n = rng.integers(1, 7)
        idx = sorted(rng.choice(STATE_SIZE, n, replace=False).tolist())
        z = rng.normal(0.0, 1.0, STATE_SIZE)
        z[3:6] = rng.uniform(-math.pi, math.pi, 3)
        b = rng.normal(0.0, 0.2, (STATE_SIZE, STATE_SIZE))
        cov = b @ b.T + 1e-3 * np.eye(STATE_SIZE)
        mask = np.zeros(STATE_SIZE, dtype=bool)
        mask[idx] = True
        threshold = math.inf if trial % 2 else 3.0
        x_ref, p_ref, d2_ref = ekf.correction_reference(x, p, idx, z, cov, threshold)
        out = f.correct(Measurement(0.0, z, cov, mask, threshold, "test"))
        assert out.mahalanobis_sq == pytest.approx(d2_ref, rel=1e-9)
        assert out.accepted == (x_ref is not None)
        if x_ref is not None:
            assert_allclose(f.x, x_ref, atol=1e-9)
            assert_allclose(f.P, p_ref, atol=1e-9)
        else:
            assert_allclose(f.x, x, atol=0)
