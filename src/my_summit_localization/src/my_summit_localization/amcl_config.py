"""amcl's ROS parameters: one declaration each, under amcl's name, with its default.

Reference: the ROS 1 amcl node's parameter list (wiki.ros.org/amcl, section 4.2
"Parameters", and ``amcl_node.cpp``). Names, defaults and meanings are amcl's, so a
course student's ``amcl_params.yaml`` loads unchanged. Three groups, as on the wiki:
overall filter, laser model, odometry model.

``AmclConfig.from_dict`` takes a parameter dict (e.g. ``rosparam`` output for ``~``),
rejects unknown keys (with the nearest known name) and bad values with a clear error,
and returns a validated config.
"""
import difflib
import math
from dataclasses import dataclass, fields

LASER_MODELS = ("likelihood_field", "likelihood_field_prob", "beam")
ODOM_MODELS = ("diff", "omni", "diff-corrected", "omni-corrected")


class ConfigError(ValueError):
    """An amcl parameter that is unknown or has a bad value; the message names it."""


@dataclass
class AmclConfig:
    """amcl's parameters (ROS names; amcl's defaults). Units in the comments."""

    # -- overall filter --------------------------------------------------------------
    min_particles: int = 100            # lower bound of the KLD-adaptive particle count [-]
    max_particles: int = 5000           # upper bound of the particle count [-]
    kld_err: float = 0.01               # max error between true and estimated distribution [-]
    kld_z: float = 0.99                 # upper standard normal quantile for (1 - p), used as z [-]
    update_min_d: float = 0.2           # translation (per axis, odom frame) before an update [m]
    update_min_a: float = math.pi / 6.0  # rotation before a filter update [rad]
    resample_interval: int = 2          # filter updates between resamplings [-]
    transform_tolerance: float = 0.1    # time the map->odom tf is post-dated into the future [s]
    recovery_alpha_slow: float = 0.0    # decay rate of the slow weight average (0 = off; 0.001 good) [-]
    recovery_alpha_fast: float = 0.0    # decay rate of the fast weight average (0 = off; 0.1 good) [-]
    # Not amcl's: per-beam scan likelihood a localized robot reaches; with recovery on
    # (recovery_alpha_fast > 0), w_fast below it injects random particles even when w_slow
    # is lower (sensor resetting; 0 = off, amcl's behaviour) [-]
    recovery_likelihood_threshold: float = 0.0
    # Not amcl's: inject random particles only while global localization is under way, from
    # global_localization() until the set has converged with w_fast at or above
    # recovery_likelihood_threshold; false = amcl's behaviour (whenever recovery is on) [-]
    recovery_global_only: bool = False
    initial_pose_x: float = 0.0         # initial pose mean x [m]
    initial_pose_y: float = 0.0         # initial pose mean y [m]
    initial_pose_a: float = 0.0         # initial pose mean yaw [rad]
    initial_cov_xx: float = 0.5 * 0.5   # initial covariance x*x [m^2]
    initial_cov_yy: float = 0.5 * 0.5   # initial covariance y*y [m^2]
    initial_cov_aa: float = (math.pi / 12.0) ** 2  # initial covariance yaw*yaw [rad^2]
    gui_publish_rate: float = -1.0      # max rate of scans/paths for visualization (-1 = off) [Hz]
    save_pose_rate: float = 0.5         # rate the last pose is stored as ~initial_pose_* (-1 = off) [Hz]
    use_map_topic: bool = False         # subscribe to `map` instead of calling static_map
    first_map_only: bool = False        # use only the first map received
    selective_resampling: bool = False  # resample only when N_eff < N/2
    # -- laser model -----------------------------------------------------------------
    laser_min_range: float = -1.0       # min range used; -1 = the scan's range_min [m]
    laser_max_range: float = -1.0       # max range used; -1 = the scan's range_max [m]
    laser_max_beams: int = 30           # evenly spaced beams used per scan [-]
    laser_z_hit: float = 0.95           # mixture weight of the hit (Gaussian) part [-]
    laser_z_short: float = 0.1          # mixture weight of the short part (beam model) [-]
    laser_z_max: float = 0.05           # mixture weight of the max-range part (beam model) [-]
    laser_z_rand: float = 0.05          # mixture weight of the random part [-]
    laser_sigma_hit: float = 0.2        # std of the hit Gaussian [m]
    laser_lambda_short: float = 0.1     # exponential decay of the short part (beam model) [1/m]
    laser_likelihood_max_dist: float = 2.0  # cap of the obstacle distance field [m]
    laser_model_type: str = "likelihood_field"  # one of LASER_MODELS
    do_beamskip: bool = False           # likelihood_field_prob: skip beams most particles disagree with
    beam_skip_distance: float = 0.5     # distance within which a beam end agrees with the map [m]
    beam_skip_threshold: float = 0.3    # fraction of agreeing particles below which a beam is skipped [-]
    beam_skip_error_threshold: float = 0.9  # skipped fraction above which no beam is skipped [-]
    # Not amcl's: skip beams only while the particle set is converged (every particle within
    # 0.5 m of the mean, amcl's pf convergence), so that global localization weighs every
    # beam; false = amcl's behaviour (skip whenever do_beamskip) [-]
    beam_skip_converged_only: bool = False
    # -- odometry model --------------------------------------------------------------
    odom_model_type: str = "diff"       # one of ODOM_MODELS
    odom_alpha1: float = 0.2            # rotation noise from rotation [-]
    odom_alpha2: float = 0.2            # rotation noise from translation [rad/m-ish, see motion_model]
    odom_alpha3: float = 0.2            # translation noise from translation [-]
    odom_alpha4: float = 0.2            # translation noise from rotation [m/rad-ish]
    odom_alpha5: float = 0.2            # omni only: strafe (translation) noise [-]
    odom_frame_id: str = "odom"         # odometry frame
    base_frame_id: str = "base_link"    # robot base frame
    global_frame_id: str = "map"        # frame of the map and of the published pose
    tf_broadcast: bool = True           # publish map->odom

    # -- construction ----------------------------------------------------------------
    @classmethod
    def from_dict(cls, params):
        """Config from a dict of amcl parameters; ConfigError on unknown keys or bad values.

        Missing keys keep amcl's defaults. Integers are accepted for float parameters and
        integral floats (e.g. 500.0) for integer ones; booleans only for booleans.
        """
        if params is None:
            params = {}
        if not isinstance(params, dict):
            raise ConfigError(f"amcl parameters must be a mapping, got {type(params).__name__}")
        known = {f.name: f for f in fields(cls)}
        values = {}
        for key, value in params.items():
            if key not in known:
                near = difflib.get_close_matches(str(key), known, n=1)
                hint = f" (did you mean '{near[0]}'?)" if near else ""
                raise ConfigError(f"unknown amcl parameter '{key}'{hint}")
            values[key] = _coerce(key, value, known[key].type)
        config = cls(**values)
        config.validate()
        return config

    def validate(self):
        """Raise ConfigError naming the first parameter whose value is out of range."""
        for f in fields(self):
            _coerce(f.name, getattr(self, f.name), f.type)
        _check(self.min_particles >= 1, "min_particles", self.min_particles, "must be >= 1")
        _check(self.max_particles >= self.min_particles, "max_particles", self.max_particles,
               f"must be >= min_particles ({self.min_particles})")
        _check(self.kld_err > 0.0, "kld_err", self.kld_err, "must be > 0")
        _check(self.kld_z > 0.0, "kld_z", self.kld_z, "must be > 0")
        for name in ("update_min_d", "update_min_a", "transform_tolerance", "laser_z_hit",
                     "laser_z_short", "laser_z_max", "laser_z_rand", "initial_cov_xx",
                     "initial_cov_yy", "initial_cov_aa", "beam_skip_distance",
                     "odom_alpha1", "odom_alpha2", "odom_alpha3", "odom_alpha4", "odom_alpha5"):
            _check(getattr(self, name) >= 0.0, name, getattr(self, name), "must be >= 0")
        _check(self.resample_interval >= 1, "resample_interval", self.resample_interval, "must be >= 1")
        for name in ("recovery_alpha_slow", "recovery_alpha_fast", "recovery_likelihood_threshold",
                     "beam_skip_threshold", "beam_skip_error_threshold"):
            v = getattr(self, name)
            _check(0.0 <= v <= 1.0, name, v, "must be within [0, 1]")
        _check(self.laser_max_beams >= 2, "laser_max_beams", self.laser_max_beams, "must be >= 2")
        _check(self.laser_sigma_hit > 0.0, "laser_sigma_hit", self.laser_sigma_hit, "must be > 0")
        _check(self.laser_lambda_short > 0.0, "laser_lambda_short", self.laser_lambda_short, "must be > 0")
        _check(self.laser_likelihood_max_dist > 0.0, "laser_likelihood_max_dist",
               self.laser_likelihood_max_dist, "must be > 0")
        _check(self.laser_z_hit + self.laser_z_rand > 0.0, "laser_z_hit",
               self.laser_z_hit, "laser_z_hit + laser_z_rand must be > 0")
        _check(self.laser_model_type in LASER_MODELS, "laser_model_type", self.laser_model_type,
               f"must be one of {', '.join(LASER_MODELS)}")
        _check(self.odom_model_type in ODOM_MODELS, "odom_model_type", self.odom_model_type,
               f"must be one of {', '.join(ODOM_MODELS)}")
        for name in ("odom_frame_id", "base_frame_id", "global_frame_id"):
            _check(bool(getattr(self, name)), name, getattr(self, name), "must be a non-empty frame id")
        return self

    def initial_pose(self):
        """(x [m], y [m], yaw [rad]) of initial_pose_x/y/a."""
        return (self.initial_pose_x, self.initial_pose_y, self.initial_pose_a)

    def initial_cov(self):
        """3x3 diagonal covariance [m^2, m^2, rad^2] of initial_cov_xx/yy/aa (as nested lists)."""
        return [[self.initial_cov_xx, 0.0, 0.0], [0.0, self.initial_cov_yy, 0.0],
                [0.0, 0.0, self.initial_cov_aa]]

    def odom_alphas(self):
        """(odom_alpha1, ..., odom_alpha5)."""
        return (self.odom_alpha1, self.odom_alpha2, self.odom_alpha3, self.odom_alpha4,
                self.odom_alpha5)


def _check(ok, name, value, why):
    if not ok:
        raise ConfigError(f"amcl parameter '{name}' = {value!r}: {why}")


def _coerce(name, value, kind):
    """Value converted to the field's type (given as a type or its string name)."""
    kind = {"int": int, "float": float, "bool": bool, "str": str}.get(kind, kind)
    if kind is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"amcl parameter '{name}' = {value!r}: must be true or false")
        return value
    if kind is str:
        if not isinstance(value, str):
            raise ConfigError(f"amcl parameter '{name}' = {value!r}: must be a string")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"amcl parameter '{name}' = {value!r}: must be a number")
    if not math.isfinite(value):
        raise ConfigError(f"amcl parameter '{name}' = {value!r}: must be finite")
    if kind is int:
        if float(value) != int(value):
            raise ConfigError(f"amcl parameter '{name}' = {value!r}: must be an integer")
        return int(value)
    return float(value)
