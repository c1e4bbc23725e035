"""robot_localization's ekf_localization_node parameters: names, defaults, meaning, checks.

read_config(params) takes the node's private parameters as a dict (rospy.get_param("~"),
or a YAML written for robot_localization) and returns an EkfConfig, or raises
ConfigError naming the parameter. Defaults are robot_localization's (noetic-devel,
documented on its wiki and in its params/ekf_template.yaml):

  frequency 30 [Hz]; sensor_timeout 1/frequency [s]; two_d_mode false;
  map_frame map, odom_frame odom, base_link_frame base_link, world_frame = odom_frame;
  publish_tf true; publish_acceleration false; print_diagnostics true; predict_to_current_time false;
  transform_time_offset 0 [s], transform_timeout 0 [s]; gravitational_acceleration 9.80665;
  smooth_lagged_data false, history_length 0 [s];
  process_noise_covariance: diagonal 0.05 0.05 0.06 0.03 0.03 0.06 0.025 0.025 0.04 0.01
  0.01 0.02 0.01 0.01 0.015 (per second); initial_estimate_covariance: diagonal 1e-9.
  Sensors odomN, imuN, poseN, twistN, N = 0, 1, ... counted until the first missing one,
  each with <name>_config (15 bools, default all false), _differential, _relative (false),
  _queue_size (1), _nodelay (false), rejection thresholds (Mahalanobis distance, default
  unlimited): odom and pose _pose_rejection_threshold, odom and twist
  _twist_rejection_threshold, imu _pose_rejection_threshold,
  _angular_velocity_rejection_threshold, _linear_acceleration_rejection_threshold, and
  imuN_remove_gravitational_acceleration (false).

Parameters robot_localization has but this node does not implement (use_control,
dynamic_process_noise_covariance, ...) raise ConfigError when turned
on, so a configuration is never silently run differently.
"""
import math
import re
from dataclasses import dataclass, field

import numpy as np

from .ekf import STATE_SIZE, STATE_NAMES
from .ekf_sensors import STANDARD_GRAVITY, SensorState

SENSOR_KINDS = ("odom", "imu", "pose", "twist")
DEFAULT_FREQUENCY = 30.0   # [Hz]
DEFAULT_PROCESS_NOISE_DIAGONAL = (0.05, 0.05, 0.06, 0.03, 0.03, 0.06, 0.025, 0.025, 0.04,
                                  0.01, 0.01, 0.02, 0.01, 0.01, 0.015)
DEFAULT_INITIAL_COVARIANCE_DIAGONAL = 1e-9
# name -> (the sensor kinds it belongs to, the SensorState field it sets)
THRESHOLDS = {"pose_rejection_threshold": (("odom", "pose", "imu"), "pose_threshold"),
              "twist_rejection_threshold": (("odom", "twist"), "twist_threshold"),
              "angular_velocity_rejection_threshold": (("imu",), "angular_velocity_threshold"),
              "linear_acceleration_rejection_threshold": (("imu",), "linear_acceleration_threshold")}
# robot_localization features this node does not have: name -> the value that is harmless
UNSUPPORTED = {"use_control": False, "dynamic_process_noise_covariance": False,
               "reset_on_time_jump": False, "disabled_at_startup": False}
# robot_localization parameters read and accepted without effect here (debug output)
IGNORED = ("debug", "debug_out_file", "permit_corrected_publication", "silent_tf_failure",
           "control_config", "control_timeout", "stamped_control",
           "acceleration_limits", "deceleration_limits", "acceleration_gains", "deceleration_gains",
           "base_link_frame_output")


class ConfigError(ValueError):
    """A parameter with a value robot_localization would not accept; the message names it."""


@dataclass
class SensorConfig:
    """One sensor: kind (odom/imu/pose/twist), name (odom0, ...), topic, queue_size, and
    the SensorState the measurement preparation keeps."""
    kind: str
    name: str
    topic: str
    queue_size: int
    nodelay: bool
    state: SensorState


@dataclass
class EkfConfig:
    frequency: float = DEFAULT_FREQUENCY          # [Hz] of the filter's output
    sensor_timeout: float = 1.0 / DEFAULT_FREQUENCY   # [s] without measurements: predict only
    two_d_mode: bool = False
    map_frame: str = "map"
    odom_frame: str = "odom"
    base_link_frame: str = "base_link"
    world_frame: str = "odom"
    publish_tf: bool = True
    publish_acceleration: bool = False
    print_diagnostics: bool = True
    transform_time_offset: float = 0.0   # [s] added to the tf's stamp
    transform_timeout: float = 0.0       # [s] how long a tf lookup waits
    predict_to_current_time: bool = False   # publish the state predicted to now, not to the last measurement
    smooth_lagged_data: bool = False     # a lagged measurement: go back and fuse again in stamp order
    history_length: float = 0.0          # [s] of filter history kept for smooth_lagged_data
    gravitational_acceleration: float = STANDARD_GRAVITY   # [m/s^2]
    process_noise_covariance: np.ndarray = None     # (15, 15) per second
    initial_estimate_covariance: np.ndarray = None  # (15, 15)
    sensors: list = field(default_factory=list)
    warnings: list = field(default_factory=list)    # said once by the node


def _bool(params, name, default):
    v = params.get(name, default)
    if not isinstance(v, bool):
        raise ConfigError(f"parameter '{name}' must be true or false, got {v!r}")
    return v


def _float(params, name, default, positive=False, nonnegative=False, allow_inf=False):
    v = params.get(name, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v) \
            or (math.isinf(v) and not (allow_inf and v > 0)):
        raise ConfigError(f"parameter '{name}' must be a {'' if allow_inf else 'finite '}number, got {v!r}")
    if positive and not v > 0:
        raise ConfigError(f"parameter '{name}' must be > 0, got {v!r}")
    if nonnegative and v < 0:
        raise ConfigError(f"parameter '{name}' must be >= 0, got {v!r}")
    return float(v)


def _frame(params, name, default):
    v = params.get(name, default)
    if not isinstance(v, str) or not v.strip() or any(c.isspace() for c in v):
        raise ConfigError(f"parameter '{name}' must be a frame name (a non-empty string without spaces), got {v!r}")
    return v.lstrip("/")   # tf2 frame ids carry no leading slash


def _matrix(params, name, default_diagonal):
    if name not in params:
        return np.diag(np.broadcast_to(np.asarray(default_diagonal, dtype=np.float64), (STATE_SIZE,))).copy()
    v = params[name]
    try:
        m = np.array(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"parameter '{name}' must be {STATE_SIZE * STATE_SIZE} numbers (a 15 x 15 matrix, "
                          f"row by row), got {v!r}") from None
    if m.size != STATE_SIZE * STATE_SIZE or isinstance(v, (str, bytes)):
        raise ConfigError(f"parameter '{name}' must be {STATE_SIZE * STATE_SIZE} numbers (a 15 x 15 matrix, "
                          f"row by row), got {m.size}")
    m = m.reshape(STATE_SIZE, STATE_SIZE)
    if not np.all(np.isfinite(m)):
        raise ConfigError(f"parameter '{name}' has a value that is not finite")
    if not np.allclose(m, m.T, rtol=0.0, atol=1e-12):
        raise ConfigError(f"parameter '{name}' must be symmetric")
    if np.any(np.diagonal(m) < 0):
        bad = [STATE_NAMES[i] for i in np.flatnonzero(np.diagonal(m) < 0)]
        raise ConfigError(f"parameter '{name}' has a negative variance for {', '.join(bad)}")
    return m


def config_vector(params, name):
    """The 15-bool `name` (<sensor>_config); ConfigError unless it is exactly 15 booleans."""
    v = params.get(name, [False] * STATE_SIZE)
    if not isinstance(v, (list, tuple)) or len(v) != STATE_SIZE or not all(isinstance(b, bool) for b in v):
        raise ConfigError(f"parameter '{name}' must be a list of {STATE_SIZE} booleans "
                          f"[{', '.join(STATE_NAMES)}], got {v!r}")
    return np.array(v, dtype=bool)


def _sensor(params, kind, name, gravity, warnings):
    topic = params[name]
    if not isinstance(topic, str) or not topic.strip():
        raise ConfigError(f"parameter '{name}' must be a topic name, got {topic!r}")
    config = config_vector(params, f"{name}_config")
    queue = params.get(f"{name}_queue_size", 1)
    if isinstance(queue, bool) or not isinstance(queue, int) or queue < 1:
        raise ConfigError(f"parameter '{name}_queue_size' must be an integer >= 1, got {queue!r}")
    state = SensorState(name=name, topic=topic, config=config,
                        differential=_bool(params, f"{name}_differential", False),
                        relative=_bool(params, f"{name}_relative", False), gravity=gravity)
    for suffix, (kinds, attr) in THRESHOLDS.items():
        key = f"{name}_{suffix}"
        if key in params:
            if kind not in kinds:
                raise ConfigError(f"parameter '{key}': a {kind} sensor has no {suffix.replace('_', ' ')}")
            setattr(state, attr, _float(params, key, math.inf, positive=True, allow_inf=True))
    if kind == "imu":
        state.remove_gravitational_acceleration = _bool(params, f"{name}_remove_gravitational_acceleration", False)
    elif f"{name}_remove_gravitational_acceleration" in params:
        raise ConfigError(f"parameter '{name}_remove_gravitational_acceleration': only an imu sensor has it")
    # flags for variables the message type does not carry: robot_localization ignores them
    carried = {"odom": slice(0, 12), "pose": slice(0, 6), "twist": slice(6, 12)}.get(kind)
    unused = np.ones(STATE_SIZE, dtype=bool)
    if kind == "imu":
        unused[3:6] = unused[9:15] = False
    else:
        unused[carried] = False
    if (config & unused).any():
        names = ", ".join(STATE_NAMES[i] for i in np.flatnonzero(config & unused))
        warnings.append(f"parameter '{name}_config': a {kind} message has no {names}; those flags are ignored")
    return SensorConfig(kind, name, topic.strip(), queue, _bool(params, f"{name}_nodelay", False), state)


SENSOR_SUFFIXES = ("", "_config", "_differential", "_relative", "_queue_size", "_nodelay",
                   "_remove_gravitational_acceleration") + tuple(f"_{t}" for t in THRESHOLDS)
SENSOR_KEY = re.compile(r"^(odom|imu|pose|twist)(\d+)(_.*)?$")


def read_config(params):
    """EkfConfig from the private parameters `params` (dict); ConfigError on bad input."""
    params = dict(params or {})
    c = EkfConfig()
    c.frequency = _float(params, "frequency", DEFAULT_FREQUENCY, positive=True)
    c.sensor_timeout = _float(params, "sensor_timeout", 1.0 / c.frequency, positive=True)
    c.two_d_mode = _bool(params, "two_d_mode", False)
    c.map_frame = _frame(params, "map_frame", "map")
    c.odom_frame = _frame(params, "odom_frame", "odom")
    c.base_link_frame = _frame(params, "base_link_frame", "base_link")
    c.world_frame = _frame(params, "world_frame", c.odom_frame)
    if len({c.map_frame, c.odom_frame, c.base_link_frame}) != 3:
        raise ConfigError(f"parameters 'map_frame' ({c.map_frame}), 'odom_frame' ({c.odom_frame}) and "
                          f"'base_link_frame' ({c.base_link_frame}) must be three different frames")
    if c.world_frame not in (c.map_frame, c.odom_frame):
        raise ConfigError(f"parameter 'world_frame' is '{c.world_frame}', an unknown frame: it must be map_frame "
                          f"('{c.map_frame}') or odom_frame ('{c.odom_frame}')")
    c.publish_tf = _bool(params, "publish_tf", True)
    c.publish_acceleration = _bool(params, "publish_acceleration", False)
    c.print_diagnostics = _bool(params, "print_diagnostics", True)
    c.predict_to_current_time = _bool(params, "predict_to_current_time", False)
    c.smooth_lagged_data = _bool(params, "smooth_lagged_data", False)
    c.history_length = _float(params, "history_length", 0.0, nonnegative=True)
    if c.smooth_lagged_data and c.history_length == 0.0:
        c.warnings.append("smooth_lagged_data is true but history_length is 0 s: no history is kept, so lagged "
                          "measurements are fused as without smoothing")
    c.transform_time_offset = _float(params, "transform_time_offset", 0.0)
    c.transform_timeout = _float(params, "transform_timeout", 0.0, nonnegative=True)
    c.gravitational_acceleration = _float(params, "gravitational_acceleration", STANDARD_GRAVITY)
    c.process_noise_covariance = _matrix(params, "process_noise_covariance", DEFAULT_PROCESS_NOISE_DIAGONAL)
    c.initial_estimate_covariance = _matrix(params, "initial_estimate_covariance",
                                            DEFAULT_INITIAL_COVARIANCE_DIAGONAL)
    for name, harmless in UNSUPPORTED.items():
        if name in params and params[name] != harmless:
            raise ConfigError(f"parameter '{name}' is {params[name]!r}: robot_localization's {name} is not "
                              f"implemented by this node (only {harmless!r})")
    used = set()
    for kind in SENSOR_KINDS:
        n = 0
        while f"{kind}{n}" in params:
            c.sensors.append(_sensor(params, kind, f"{kind}{n}", c.gravitational_acceleration, c.warnings))
            used.add(f"{kind}{n}")
            n += 1
    for key in sorted(params):
        m = SENSOR_KEY.match(str(key))
        if m and f"{m.group(1)}{m.group(2)}" not in used:
            # robot_localization counts odom0, odom1, ... and stops at the first gap
            c.warnings.append(f"parameter '{key}' is ignored: sensors are read as {m.group(1)}0, {m.group(1)}1, ... "
                              f"up to the first one not set, and '{m.group(1)}{m.group(2)}' comes after it")
    if not c.sensors:
        c.warnings.append("no sensor configured (odom0, imu0, pose0, twist0): the filter only predicts")
    return c


def known_names(params):
    """Every parameter name this node reads or accepts, given the sensors in `params`
    (for summit_nav_common.params.unread_notes)."""
    names = {"frequency", "sensor_timeout", "two_d_mode", "map_frame", "odom_frame", "base_link_frame",
             "world_frame", "publish_tf", "publish_acceleration", "print_diagnostics", "transform_time_offset",
             "transform_timeout", "gravitational_acceleration", "process_noise_covariance",
             "initial_estimate_covariance", "diagnostic_period", "predict_to_current_time",
             "smooth_lagged_data", "history_length"} | set(UNSUPPORTED) | set(IGNORED)
    for key in params:
        m = SENSOR_KEY.match(str(key))
        if m and not m.group(3):
            names.update(f"{key}{suffix}" for suffix in SENSOR_SUFFIXES)
    return names
