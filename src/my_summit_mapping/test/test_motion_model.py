"""gmapping's odometry sampling: mean and spread of the samples."""
import numpy as np
from numpy.testing import assert_allclose

from my_summit_mapping import motion_model

N = 40000  # samples: the standard error of a std estimate is ~0.4 % [-]


def test_sample_mean_and_spread_straight_move():
    rng = np.random.default_rng(1)
    poses = np.zeros((N, 3))
    srr, srt, str_, stt = 0.1, 0.2, 0.1, 0.2
    out = motion_model.sample_motion(poses, np.zeros(3), np.array([1.0, 0.0, 0.0]),
                                     srr, srt, str_, stt, rng)
    assert_allclose(out.mean(axis=0), [1.0, 0.0, 0.0], atol=0.005)
    # std_x = srr*1, std_y = 0.3*srr*1, std_theta = srt*1 (gmapping's code semantics)
    assert_allclose(out.std(axis=0), [0.1, 0.03, 0.2], rtol=0.03)


def test_sample_rotation_and_frame():
    rng = np.random.default_rng(2)
    start = np.tile([1.0, 2.0, np.pi / 2], (N, 1))
    old, new = np.array([5.0, 5.0, 0.0]), np.array([5.5, 5.0, 0.3])  # 0.5 m ahead, 0.3 rad left
    out = motion_model.sample_motion(start, old, new, 0.1, 0.2, 0.1, 0.2, rng)
    # in the particle's frame (facing +y) "ahead" is +y
    assert_allclose(out.mean(axis=0), [1.0, 2.5, np.pi / 2 + 0.3], atol=0.01)
    std = motion_model.noise_std(motion_model.odometry_increment(old, new), 0.1, 0.2, 0.1, 0.2)
    assert_allclose(std, [0.1 * 0.5 + 0.1 * 0.3, 0.1 * 0.3 + 0.03 * 0.5, 0.2 * 0.3 + 0.2 * 0.5])
    assert_allclose(out.std(axis=0), [std[1], std[0], std[2]], rtol=0.03)  # axes swapped by the heading


def test_no_motion_no_noise_and_in_place():
    rng = np.random.default_rng(3)
    poses = np.array([[1.0, -1.0, 3.0], [0.0, 0.0, -3.0]])
    expected = poses.copy()
    motion_model.sample_motion(poses, np.ones(3), np.ones(3), 0.1, 0.2, 0.1, 0.2, rng, out=poses)
    assert_allclose(poses, expected)
