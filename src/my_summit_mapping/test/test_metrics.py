"""ATE with rigid alignment, map precision/recall."""
import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_mapping import metrics


def _transform(traj, yaw, tx, ty):
    c, s = np.cos(yaw), np.sin(yaw)
    out = traj.copy()
    out[:, 0] = c * traj[:, 0] - s * traj[:, 1] + tx
    out[:, 1] = s * traj[:, 0] + c * traj[:, 1] + ty
    out[:, 2] = traj[:, 2] + yaw
    return out


def test_ate_of_rigidly_moved_trajectory_is_zero():
    rng = np.random.default_rng(4)
    ref = np.cumsum(rng.normal(size=(200, 3)), axis=0)
    est = _transform(ref, 2.5, -30.0, 12.0)
    assert metrics.ate_rmse(est, ref) == pytest.approx(0.0, abs=1e-9)
    rot, t = metrics.rigid_alignment_2d(est, ref)
    assert_allclose(rot, [[np.cos(-2.5), -np.sin(-2.5)], [np.sin(-2.5), np.cos(-2.5)]], atol=1e-9)


def test_ate_of_known_error():
    # a square and the same square 10 % larger: by symmetry the best rigid alignment is
    # the identity, so every corner keeps its 0.1 * sqrt(2) m error
    ref = np.array([[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0], [1.0, -1.0, 0.0]])
    est = ref * [1.1, 1.1, 1.0]
    assert metrics.ate_rmse(est, ref) == pytest.approx(0.1 * np.sqrt(2.0), abs=1e-9)


def test_ate_rejects_mismatched_lengths():
    with pytest.raises(ValueError):
        metrics.ate_rmse(np.zeros((3, 3)), np.zeros((4, 3)))


def test_precision_recall():
    walls = np.zeros((10, 10), bool)
    walls[5, :] = True
    occ = np.zeros_like(walls)
    occ[6, 0:5] = True     # within one cell of the wall
    occ[0, 0:5] = True     # far from any wall
    assert metrics.map_precision(occ, walls) == pytest.approx(0.5)
    assert metrics.map_recall(occ, walls) == pytest.approx(6 / 10)  # columns 0..5 covered
    seen = np.zeros_like(walls)
    seen[:, :3] = True      # the laser only looked at columns 0..2 (+1 cell tolerance)
    assert metrics.map_recall(occ, walls, seen) == pytest.approx(1.0)
    assert np.isnan(metrics.map_precision(np.zeros_like(walls), walls))
    with pytest.raises(ValueError):
        metrics.map_precision(occ, walls[:5])
