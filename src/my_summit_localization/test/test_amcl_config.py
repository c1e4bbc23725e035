"""amcl parameters: amcl's defaults, loading the package's YAML, and bad input refused."""
import math
import os

import pytest
import yaml

from my_summit_localization.amcl_config import AmclConfig, ConfigError

PARAMS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "amcl_params.yaml")


def test_defaults_are_amcls():
    c = AmclConfig()
    assert (c.min_particles, c.max_particles, c.kld_err, c.kld_z) == (100, 5000, 0.01, 0.99)
    assert (c.update_min_d, c.update_min_a, c.resample_interval) == (0.2, pytest.approx(math.pi / 6), 2)
    assert (c.recovery_alpha_slow, c.recovery_alpha_fast) == (0.0, 0.0)
    assert c.recovery_likelihood_threshold == 0.0   # ours, off: amcl's behaviour
    assert c.initial_cov_xx == 0.25 and c.initial_cov_aa == pytest.approx((math.pi / 12) ** 2)
    assert (c.laser_max_beams, c.laser_z_hit, c.laser_z_short, c.laser_z_max, c.laser_z_rand) == \
        (30, 0.95, 0.1, 0.05, 0.05)
    assert (c.laser_sigma_hit, c.laser_lambda_short, c.laser_likelihood_max_dist) == (0.2, 0.1, 2.0)
    assert c.laser_model_type == "likelihood_field" and c.odom_model_type == "diff"
    assert c.odom_alphas() == (0.2,) * 5
    assert (c.odom_frame_id, c.base_frame_id, c.global_frame_id) == ("odom", "base_link", "map")


def test_package_yaml_loads():
    with open(PARAMS) as f:
        c = AmclConfig.from_dict(yaml.safe_load(f))
    assert c.max_particles >= c.min_particles


def test_int_and_float_coercion():
    c = AmclConfig.from_dict({"min_particles": 500.0, "update_min_d": 1, "use_map_topic": True})
    assert c.min_particles == 500 and isinstance(c.min_particles, int)
    assert c.update_min_d == 1.0 and isinstance(c.update_min_d, float)


@pytest.mark.parametrize("params, match", [
    ({"min_particle": 10}, "unknown amcl parameter 'min_particle'.*min_particles"),
    ({"min_particles": 10.5}, "must be an integer"),
    ({"min_particles": True}, "must be a number"),
    ({"kld_err": "small"}, "must be a number"),
    ({"use_map_topic": 1}, "must be true or false"),
    ({"min_particles": 600, "max_particles": 500}, "max_particles.*>= min_particles"),
    ({"laser_model_type": "beams"}, "laser_model_type"),
    ({"odom_model_type": "ackermann"}, "odom_model_type"),
    ({"recovery_alpha_fast": 1.5}, "within \\[0, 1\\]"),
    ({"recovery_likelihood_threshold": -0.1}, "recovery_likelihood_threshold.*within"),
    ({"laser_sigma_hit": 0.0}, "laser_sigma_hit.*> 0"),
    ({"odom_alpha3": -0.1}, "odom_alpha3.*>= 0"),
    ({"update_min_d": float("nan")}, "finite"),
    ({"resample_interval": 0}, "resample_interval"),
    ({"laser_max_beams": 1}, "laser_max_beams"),
    ({"base_frame_id": ""}, "base_frame_id"),
])
def test_bad_values_refused(params, match):
    with pytest.raises(ConfigError, match=match):
        AmclConfig.from_dict(params)


def test_not_a_mapping():
    with pytest.raises(ConfigError, match="mapping"):
        AmclConfig.from_dict([1, 2])
