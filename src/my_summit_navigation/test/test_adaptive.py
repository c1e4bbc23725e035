"""Unit tests of the adaptive parameters' decision (my_summit_navigation.adaptive)."""
import numpy as np
import pytest
from numpy.testing import assert_allclose

from my_summit_navigation import adaptive as ad

RES = 0.05   # [m] cell side


def grid_with_wall(width=80, height=80, wall_col=None):
    """A free (H, W) costmap, with one lethal column when wall_col is given."""
    g = np.zeros((height, width), np.int8)
    if wall_col is not None:
        g[:, wall_col] = ad.LETHAL
    return g


def clutter_oracle(grid, res, origin, robot, radius):
    """Slow reference: every cell's centre tested."""
    rows, cols = np.indices(grid.shape)
    x = origin[0] + (cols + 0.5) * res
    y = origin[1] + (rows + 0.5) * res
    inside = np.hypot(x - robot[0], y - robot[1]) <= radius
    return np.count_nonzero(grid[inside] == ad.LETHAL) / inside.sum() if inside.any() else None


def test_free_space_has_no_clutter_and_a_full_grid_is_all_clutter():
    assert ad.clutter(grid_with_wall(), RES, (0, 0), (2, 2), 1.5) == 0.0
    full = np.full((80, 80), ad.LETHAL, np.int8)
    assert ad.clutter(full, RES, (0, 0), (2, 2), 1.5) == 1.0


def test_only_lethal_cells_count_not_inscribed_or_unknown():
    g = grid_with_wall()
    g[:, :40] = 99     # inscribed cost as published (costmap_2d's 253)
    g[:40, 40:] = -1   # unknown
    assert ad.clutter(g, RES, (0, 0), (2, 2), 1.5) == 0.0


def test_matches_the_cell_by_cell_oracle_off_centre_and_at_the_edges():
    rng = np.random.default_rng(4)
    g = np.where(rng.random((60, 90)) < 0.2, ad.LETHAL, 0).astype(np.int8)
    origin = (-1.3, 2.05)
    for robot in [(0.7, 3.4), (-1.2, 2.1), (3.1, 5.0), (1.234, 4.567)]:
        assert_allclose(ad.clutter(g, RES, origin, robot, 1.5), clutter_oracle(g, RES, origin, robot, 1.5))


def test_a_wall_beside_the_robot_is_a_known_share():
    # a lethal column (centre x = 60.5 cells = 3.025 m) 1.025 m from the robot: its cells
    # within 1.5 m span 2 * sqrt(1.5^2 - 1.025^2) m of the circle's pi * 1.5^2 m^2
    g = grid_with_wall(wall_col=60)
    share = ad.clutter(g, RES, (0, 0), (2.0, 2.0), 1.5)
    expected = (2 * np.sqrt(1.5 ** 2 - 1.025 ** 2) / RES) / (np.pi * (1.5 / RES) ** 2)
    assert_allclose(share, expected, rtol=0.05)


def test_a_robot_off_the_costmap_has_no_reading():
    assert ad.clutter(grid_with_wall(), RES, (0, 0), (10.0, 10.0), 1.5) is None


def test_switches_in_at_enter_and_out_at_leave_after_the_dwell():
    s = ad.Hysteresis(enter=0.12, leave=0.08, min_dwell=5.0)
    assert s.update(0.0, 0.0) is None
    assert s.update(6.0, 0.119) is None and s.state == ad.OPEN
    assert s.update(6.5, 0.12) == ad.CLUTTERED
    assert s.update(20.0, 0.081) is None and s.state == ad.CLUTTERED
    assert s.update(20.5, 0.08) == ad.OPEN


def test_a_clutter_hovering_at_a_threshold_switches_once():
    """Noise of +-0.03 around the enter threshold, read at 2 Hz for ten minutes: one switch
    in (the first crossing after the start dwell) and never out, since it never falls to
    leave."""
    rng = np.random.default_rng(7)
    s = ad.Hysteresis(enter=0.12, leave=0.08, min_dwell=5.0)
    switches = [t for t in np.arange(0, 600, 0.5) if s.update(t, 0.12 + rng.uniform(-0.03, 0.03)) is not None]
    assert len(switches) == 1 and s.state == ad.CLUTTERED


def test_a_clutter_swinging_across_both_thresholds_switches_at_most_once_per_dwell():
    s = ad.Hysteresis(enter=0.12, leave=0.08, min_dwell=5.0)
    times = np.arange(0, 120, 0.5)
    switches = [t for t in times if s.update(t, 0.2 if int(t) % 2 else 0.0) is not None]
    assert len(switches) >= 2
    assert np.all(np.diff(switches) >= 5.0)
    assert switches[0] >= 5.0   # the start counts as a switch: no change in the first dwell


def test_no_reading_changes_nothing():
    s = ad.Hysteresis(min_dwell=0.0)
    assert s.update(0.0, None) is None and s.state == ad.OPEN
    assert s.update(1.0, 0.5) == ad.CLUTTERED
    assert s.update(2.0, None) is None and s.state == ad.CLUTTERED


@pytest.mark.parametrize("kwargs, word", [
    ({"enter": 0.1, "leave": 0.1}, "below ~enter_clutter"),
    ({"enter": 0.05, "leave": 0.08}, "below ~enter_clutter"),
    ({"enter": 1.5}, "~enter_clutter"),
    ({"leave": -0.1}, "~leave_clutter"),
    ({"min_dwell": -1.0}, "~min_dwell"),
    ({"enter": float("nan")}, "~enter_clutter"),
])
def test_bad_configurations_name_the_parameter(kwargs, word):
    with pytest.raises(ad.AdaptiveError, match=word):
        ad.Hysteresis(**kwargs)


def test_cluttered_profile_lowers_speed_raises_inflation_never_the_reverse():
    open_profile = {"DWAPlannerROS": {"max_vel_x": 1.0},
                    "local_costmap/inflation_layer": {"inflation_radius": 0.8},
                    "global_costmap/inflation_layer": {"inflation_radius": 1.2}}
    prof, notes = ad.cluttered_profile(open_profile, 0.2, 1.0)
    assert prof == {"DWAPlannerROS": {"max_vel_x": 0.2},
                    "local_costmap/inflation_layer": {"inflation_radius": 1.0},
                    "global_costmap/inflation_layer": {"inflation_radius": 1.2}}
    assert len(notes) == 1 and "global_costmap/inflation_layer" in notes[0]
    prof, notes = ad.cluttered_profile({"TrajectoryPlannerROS": {"max_vel_x": 0.15}}, 0.2, 1.0)
    assert prof["TrajectoryPlannerROS"]["max_vel_x"] == 0.15 and "above" in notes[0]
