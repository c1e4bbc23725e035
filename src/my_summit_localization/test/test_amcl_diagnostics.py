"""amcl's "Standard deviation" check, as amcl_node.cpp's standardDeviationDiagnostics."""
import numpy as np
import pytest

from my_summit_localization.diagnostics import std_warn_levels, standard_deviation_check
from summit_nav_common.diagnostic_checks import OK, WARN

LEVELS = dict(std_warn_level_x=0.2, std_warn_level_y=0.2, std_warn_level_yaw=0.1)
KEYS = ["std_x", "std_y", "std_yaw", "std_warn_level_x", "std_warn_level_y", "std_warn_level_yaw"]


def test_small_covariance_is_ok_with_amcls_keys():
    c = standard_deviation_check(np.diag([0.01, 0.0004, 0.0025]), **LEVELS)
    assert (c.level, c.message) == (OK, "OK")
    assert [k for k, _ in c.values] == KEYS
    assert dict(c.values) == {"std_x": "0.1", "std_y": "0.02", "std_yaw": "0.05", "std_warn_level_x": "0.2",
                              "std_warn_level_y": "0.2", "std_warn_level_yaw": "0.1"}


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_any_axis_above_its_level_is_too_large(axis):
    var = [0.01, 0.01, 0.001]
    var[axis] = [0.2, 0.2, 0.1][axis] ** 2 * 1.01
    c = standard_deviation_check(np.diag(var), **LEVELS)
    assert (c.level, c.message) == (WARN, "Too large")


def test_exactly_at_the_level_is_ok():
    # amcl compares with '>': at the level is still OK
    assert standard_deviation_check(np.diag([0.25, 0.25, 0.0625]), 0.5, 0.5, 0.25).level == OK


def test_before_the_first_pose_reads_zeros_as_amcl():
    c = standard_deviation_check(None, **LEVELS)
    assert (c.level, c.message) == (OK, "OK") and dict(c.values)["std_x"] == "0"


def test_spread_particles_warn():
    # global localization over a 20 m x 20 m building: metres of spread
    c = standard_deviation_check(np.diag([30.0, 25.0, 3.3]), **LEVELS)
    assert c.level == WARN


def test_warn_levels_from_parameters():
    assert std_warn_levels({}) == LEVELS
    assert std_warn_levels({"std_warn_level_x": 1}) == dict(LEVELS, std_warn_level_x=1.0)
    for bad in ("0.2", -0.1, True, float("nan")):
        with pytest.raises(ValueError, match="parameter 'std_warn_level_yaw'"):
            std_warn_levels({"std_warn_level_yaw": bad})
