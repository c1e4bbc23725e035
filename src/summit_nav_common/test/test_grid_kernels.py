"""The compiled grid kernels against the OpenCV calls they replaced (the oracle), to the bit."""
import cv2
import numpy as np
import numpy.testing as npt
import pytest

from summit_nav_common import grid_kernels as gk

SHAPES = [(1, 1), (1, 7), (9, 1), (2, 3), (37, 53), (120, 90), (301, 257)]


def random_mask(rng, shape, p_zero):
    return (rng.random(shape) >= p_zero).astype(np.uint8) * 255


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("p_zero", [0.0, 0.002, 0.05, 0.5, 1.0])
def test_distance_transform_equals_opencv_precise(shape, p_zero):
    rng = np.random.default_rng(hash((shape, p_zero)) % 2**32)
    src = random_mask(rng, shape, p_zero)
    npt.assert_array_equal(gk.distance_transform(src),
                           cv2.distanceTransform(src, cv2.DIST_L2, cv2.DIST_MASK_PRECISE))


def test_distance_transform_on_a_large_sparse_grid():
    """Far from the few zero cells the envelope's float intersections matter most."""
    rng = np.random.default_rng(7)
    src = np.full((900, 1300), 1, np.uint8)
    src[rng.integers(0, 900, 5), rng.integers(0, 1300, 5)] = 0
    npt.assert_array_equal(gk.distance_transform(src),
                           cv2.distanceTransform(src, cv2.DIST_L2, cv2.DIST_MASK_PRECISE))


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("p_zero", [0.0, 0.01, 0.2, 1.0])
def test_chamfer_labels_equal_opencv(shape, p_zero):
    rng = np.random.default_rng(hash((shape, p_zero, 1)) % 2**32)
    src = random_mask(rng, shape, p_zero)
    dist, labels = gk.chamfer_labels(src)
    ref_d, ref_l = cv2.distanceTransformWithLabels(src, cv2.DIST_L2, cv2.DIST_MASK_5,
                                                   labelType=cv2.DIST_LABEL_PIXEL)
    npt.assert_array_equal(dist, ref_d)
    npt.assert_array_equal(labels, ref_l)


def test_chamfer_labels_of_a_plan_line():
    """DWA's use: a polyline of zero cells in a 255 field."""
    src = np.full((80, 80), 255, np.uint8)
    t = np.linspace(0, 1, 400)
    src[(10 + 60 * t).astype(int), (5 + 70 * t ** 2).astype(int)] = 0
    dist, labels = gk.chamfer_labels(src)
    ref_d, ref_l = cv2.distanceTransformWithLabels(src, cv2.DIST_L2, cv2.DIST_MASK_5,
                                                   labelType=cv2.DIST_LABEL_PIXEL)
    npt.assert_array_equal(dist, ref_d)
    npt.assert_array_equal(labels, ref_l)


@pytest.mark.parametrize("shape", [(1, 1), (1, 5), (4, 1), (31, 47), (100, 100)])
def test_remap_bilinear_equals_opencv(shape):
    rng = np.random.default_rng(shape[0] * 1000 + shape[1])
    field = rng.uniform(-2.0, 5.0, shape).astype(np.float32)
    h, w = shape
    n = 5000
    fx = rng.uniform(-3.0, w + 2.0, n).astype(np.float32)
    fy = rng.uniform(-3.0, h + 2.0, n).astype(np.float32)
    fx[:50] = np.round(fx[:50] * 32) / 32 + 1 / 64     # halfway between 1/32 steps: the rounding
    fx[50:60] = 1e6                                      # beyond OpenCV's short coordinates
    fy[60:70] = -1e6
    ours = gk.remap_bilinear(field, fx.reshape(50, 100), fy.reshape(50, 100), -1.0e6)
    ref = cv2.remap(field, fx.reshape(50, 100), fy.reshape(50, 100), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=-1.0e6)
    npt.assert_array_equal(ours, ref)


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (5, 1), (23, 37), (60, 41)])
@pytest.mark.parametrize("k", [1, 2, 3, 4, 5])
def test_upsample_linear_equals_opencv_resize(shape, k):
    rng = np.random.default_rng(shape[0] * 97 + shape[1] + k)
    grid = rng.uniform(0.0, 5e4, shape).astype(np.float32)
    ref = cv2.resize(grid, (shape[1] * k, shape[0] * k), interpolation=cv2.INTER_LINEAR)
    npt.assert_array_equal(gk.upsample_linear(grid, k), ref)


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_dilate_and_erode_equal_opencv(dtype):
    rng = np.random.default_rng(3)
    for shape in [(1, 1), (1, 9), (8, 1), (40, 33)]:
        grid = (rng.random(shape) * 200).astype(dtype)
        kernel = np.ones((3, 3), np.uint8)
        npt.assert_array_equal(gk.dilate3(grid), cv2.dilate(grid, kernel))
        npt.assert_array_equal(gk.erode3(grid), cv2.erode(grid, kernel))


@pytest.mark.parametrize("p", [0.0, 0.3, 0.6, 1.0])
def test_components_partition_equals_opencv(p):
    """The same cells joined as cv2.connectedComponents (8-connected); numbering aside."""
    rng = np.random.default_rng(int(p * 10))
    mask = (rng.random((70, 61)) < p).astype(np.uint8)
    ours = gk.components8(mask)
    n, ref = cv2.connectedComponents(mask, connectivity=8, ltype=cv2.CV_32S)
    assert ours.max() == n - 1
    assert np.array_equal(ours == 0, ref == 0)
    pairs = set(zip(ours[mask > 0].tolist(), ref[mask > 0].tolist()))
    assert len(pairs) == n - 1    # a bijection between the two labellings
