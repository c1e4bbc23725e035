"""amcl's diagnostic checks (pure): the real amcl's "Standard deviation", and the parameters.

standard_deviation_check is amcl_node.cpp's standardDeviationDiagnostics: the standard
deviations of the last published pose (amcl_pose's covariance, x, y and yaw) against
~std_warn_level_x / _y / _yaw, WARN "Too large" when any exceeds its level, else OK "OK",
with the same six keys. Before the first pose it reads a zero covariance and says OK, as
amcl does (its last_published_pose starts zeroed); the scan-rate check tells that nothing
is coming. The node's scan check is summit_nav_common.diagnostic_checks.scan_rate_check.
"""
import math

import numpy as np

from summit_nav_common.diagnostic_checks import OK, WARN, Check, fmt

# amcl's parameters for the check, with its defaults
STD_WARN_DEFAULTS = {"std_warn_level_x": 0.2,     # [m]
                     "std_warn_level_y": 0.2,     # [m]
                     "std_warn_level_yaw": 0.1}   # [rad]
SCAN_TIMEOUT = 15.0   # [s] no scan for this long is an ERROR (amcl's laser_check_interval_)
HARDWARE_ID = "None"  # amcl's setHardwareID("None")


def std_warn_levels(params: dict) -> dict:
    """The three warn levels from amcl's private parameters (defaults where absent);
    ValueError naming a parameter that is not a finite, non-negative number."""
    out = {}
    for name, default in STD_WARN_DEFAULTS.items():
        value = params.get(name, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or value < 0:
            raise ValueError(f"parameter '{name}' = {value!r}: must be a non-negative number")
        out[name] = float(value)
    return out


def standard_deviation_check(cov, std_warn_level_x: float, std_warn_level_y: float,
                             std_warn_level_yaw: float) -> Check:
    """amcl's standardDeviationDiagnostics. cov: the (3, 3) covariance of x [m], y [m],
    yaw [rad] of the last published pose, or None before the first (read as zeros)."""
    c = np.zeros((3, 3)) if cov is None else np.asarray(cov, dtype=float)
    std_x, std_y, std_yaw = (math.sqrt(c[i, i]) if c[i, i] >= 0 else math.nan for i in range(3))
    values = (("std_x", fmt(std_x)), ("std_y", fmt(std_y)), ("std_yaw", fmt(std_yaw)),
              ("std_warn_level_x", fmt(float(std_warn_level_x))),
              ("std_warn_level_y", fmt(float(std_warn_level_y))),
              ("std_warn_level_yaw", fmt(float(std_warn_level_yaw))))
    if std_x > std_warn_level_x or std_y > std_warn_level_y or std_yaw > std_warn_level_yaw:
        return Check(WARN, "Too large", values)
    return Check(OK, "OK", values)
