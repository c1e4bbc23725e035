"""rt_move_base_reconfigure_tpr.py's ground-truth speed (windowed_speeds): a known track's
speed, the time filter, and no value (not an IndexError) before any sample arrived."""
import importlib.util
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location(
    "rt_move_base_reconfigure_tpr", os.path.join(HERE, "rt_move_base_reconfigure_tpr.py"))
rt = importlib.util.module_from_spec(spec)
spec.loader.exec_module(rt)


def test_no_sample_yet_gives_no_speed():
    # the test's first speed.now() can come before /base_pose_ground_truth's first message
    assert len(rt.windowed_speeds([])) == 0
    assert len(rt.windowed_speeds([], t_from=10.0)) == 0
    assert len(rt.windowed_speeds([(1.0, 0.0, 0.0)])) == 0


def test_span_below_the_window_gives_no_speed():
    samples = [(t, 0.1 * t, 0.0) for t in np.arange(0.0, rt.SPEED_WINDOW - 0.05, 0.1)]
    assert len(rt.windowed_speeds(samples)) == 0


def test_constant_speed_track():
    # 0.4 m/s along a diagonal, sampled at 10 Hz for 3 s
    t = np.arange(0.0, 3.0, 0.1)
    v = 0.4
    samples = [(ti, v * ti / np.sqrt(2), v * ti / np.sqrt(2)) for ti in t]
    s = rt.windowed_speeds(samples)
    assert len(s) == len(t) - int(round(rt.SPEED_WINDOW / 0.1))
    np.testing.assert_allclose(s, v, rtol=1e-9)


def test_time_filter_drops_samples_outside():
    # stopped until t=2, then 0.5 m/s: from t=2 on only the driving speed is seen
    t = np.arange(0.0, 5.0, 0.1)
    samples = [(ti, max(0.0, ti - 2.0) * 0.5, 0.0) for ti in t]
    assert rt.windowed_speeds(samples).min() < 0.01
    after = rt.windowed_speeds(samples, t_from=2.0 - 1e-9)
    np.testing.assert_allclose(after, 0.5, rtol=1e-9)
    assert len(rt.windowed_speeds(samples, t_from=2.0, t_to=2.3)) == 0
