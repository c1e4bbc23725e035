"""gmapping's parameters, under the ROS parameter names of slam_gmapping.

Reference: ROS wiki, http://wiki.ros.org/gmapping (section 4.1.4 "Parameters"), and
slam_gmapping.cpp for the defaults the wiki leaves open (maxRange). Every field keeps the
exact ROS name (hence the camelCase) so a course YAML maps 1:1 onto it.

Note on the four odometry noise parameters: the wiki describes srt as "translation as a
function of rotation" and str as "rotation as a function of translation", but gmapping's
code (MotionModel::drawFromMotion) uses them the other way round. This project follows
the code (see motion_model.py), so a course YAML tuned on the real gmapping behaves the
same here.
"""
import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional


@dataclass
class SlamConfig:
    """gmapping's parameters; units in the comments. Build with `SlamConfig.from_dict`."""

    # --- node-level (used by the ROS adapter, kept here so there is one declaration) ---
    inverted_laser: str = "false"      # deprecated in gmapping; laser upside down ("true"/"false")
    throttle_scans: int = 1            # process 1 scan out of every this many [-]
    base_frame: str = "base_link"      # robot base frame [tf frame id]
    map_frame: str = "map"             # map frame [tf frame id]
    odom_frame: str = "odom"           # odometry frame [tf frame id]
    map_update_interval: float = 5.0   # time between map publications [s]
    transform_publish_period: float = 0.05  # time between map->odom tf broadcasts [s]; 0 disables
    tf_delay: float = 0.05             # tf delay (= transform_publish_period in gmapping) [s]
    occ_thresh: float = 0.25           # occupancy frequency above which a cell is occupied [0..1]

    # --- laser ---
    maxUrange: float = 80.0            # maximum usable laser range; beams are cropped to it [m]
    maxRange: Optional[float] = None   # maximum sensor range; readings >= this are "no return" [m];
                                       # None = scan range_max - 0.01 (slam_gmapping's default)

    # --- scan matcher ---
    sigma: float = 0.05                # endpoint matching score sigma: exp(-d^2/sigma) [m^2 effectively]
    kernelSize: int = 1                # search window for a beam's correspondence, +- cells [cells]
    lstep: float = 0.05                # initial hill-climbing translation step [m]
    astep: float = 0.05                # initial hill-climbing rotation step [rad]
    iterations: int = 5                # number of step halvings in the hill climbing [-]
    lsigma: float = 0.075              # beam likelihood sigma for importance weights [m^2 effectively]
    ogain: float = 3.0                 # gain smoothing the weights: w = exp(l / (ogain * N)) [-]
    lskip: int = 0                     # use only every (lskip+1)-th beam for matching/likelihood [-]
    minimumScore: float = 0.0          # below this match score the odometry pose is kept [score]

    # --- motion model (gmapping's MotionModel names; see module docstring) ---
    srr: float = 0.1                   # translation noise per translation [m/m]
    srt: float = 0.2                   # rotation noise per translation [rad/m] (code semantics)
    str: float = 0.1                   # translation noise per rotation [m/rad] (code semantics)
    stt: float = 0.2                   # rotation noise per rotation [rad/rad]

    # --- filter update gating and resampling ---
    linearUpdate: float = 1.0          # process a scan after this much translation [m]
    angularUpdate: float = 0.5         # process a scan after this much rotation [rad]
    temporalUpdate: float = -1.0       # process a scan if this long since the last one [s]; <0 off
    resampleThreshold: float = 0.5     # resample when Neff < resampleThreshold * particles [-]
    particles: int = 30                # number of particles [-]

    # --- initial map extent and resolution ---
    xmin: float = -100.0               # initial map min x [m]
    ymin: float = -100.0               # initial map min y [m]
    xmax: float = 100.0                # initial map max x [m]
    ymax: float = 100.0                # initial map max y [m]
    delta: float = 0.05                # map resolution [m/cell]

    # --- likelihood sampling (gmapping's proposal sampling; kept for parameter
    #     compatibility: like slam_gmapping's default path, this core does not use them) ---
    llsamplerange: float = 0.01        # translational sampling range for the likelihood [m]
    llsamplestep: float = 0.01         # translational sampling step for the likelihood [m]
    lasamplerange: float = 0.005       # angular sampling range for the likelihood [rad]
    lasamplestep: float = 0.005        # angular sampling step for the likelihood [rad]

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Raise ValueError naming the first parameter whose value is out of range."""
        positive = ("maxUrange", "sigma", "lstep", "astep", "lsigma", "ogain", "delta",
                    "llsamplerange", "llsamplestep", "lasamplerange", "lasamplestep")
        for name in positive:
            value = getattr(self, name)
            if not _is_finite_number(value) or value <= 0.0:
                raise ValueError(f"gmapping parameter '{name}' must be a finite number > 0, got {value!r}")
        non_negative = ("srr", "srt", "str", "stt", "linearUpdate", "angularUpdate",
                        "map_update_interval", "transform_publish_period", "tf_delay")
        for name in non_negative:
            value = getattr(self, name)
            if not _is_finite_number(value) or value < 0.0:
                raise ValueError(f"gmapping parameter '{name}' must be a finite number >= 0, got {value!r}")
        for name in ("minimumScore", "temporalUpdate", "xmin", "ymin", "xmax", "ymax"):
            if not _is_finite_number(getattr(self, name)):
                raise ValueError(f"gmapping parameter '{name}' must be a finite number, got {getattr(self, name)!r}")
        for name, low in (("kernelSize", 0), ("iterations", 0), ("lskip", 0),
                          ("particles", 1), ("throttle_scans", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"gmapping parameter '{name}' must be an integer >= {low}, got {value!r}")
        if self.maxRange is not None and (not _is_finite_number(self.maxRange) or self.maxRange <= 0.0):
            raise ValueError(f"gmapping parameter 'maxRange' must be a finite number > 0 or None, got {self.maxRange!r}")
        if not 0.0 <= self.resampleThreshold <= 1.0:
            raise ValueError(f"gmapping parameter 'resampleThreshold' must be in [0, 1], got {self.resampleThreshold!r}")
        if not 0.0 < self.occ_thresh < 1.0:
            raise ValueError(f"gmapping parameter 'occ_thresh' must be in (0, 1), got {self.occ_thresh!r}")
        if self.xmin >= self.xmax or self.ymin >= self.ymax:
            raise ValueError(f"gmapping map extent is empty: xmin={self.xmin} xmax={self.xmax} "
                             f"ymin={self.ymin} ymax={self.ymax}")
        for name in ("inverted_laser", "base_frame", "map_frame", "odom_frame"):
            if not isinstance(getattr(self, name), str):
                raise ValueError(f"gmapping parameter '{name}' must be a string, got {getattr(self, name)!r}")

    @classmethod
    def from_dict(cls, params: Mapping[str, Any]) -> "SlamConfig":
        """Build a config from {ros_param_name: value} (e.g. a YAML or rosparam dict).

        Integers are accepted where floats are expected; unknown names and out-of-range
        values raise ValueError with the offending name, so a typo in a YAML is not
        silently ignored.
        """
        fields = {f.name: f for f in dataclasses.fields(cls)}
        unknown = sorted(set(params) - set(fields))
        if unknown:
            raise ValueError(f"unknown gmapping parameter(s): {', '.join(unknown)}; "
                             f"known: {', '.join(sorted(fields))}")
        kwargs: Dict[str, Any] = {}
        for name, value in params.items():
            default = fields[name].default
            if isinstance(default, float) or name == "maxRange":
                if value is None and name == "maxRange":
                    kwargs[name] = None
                    continue
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    raise ValueError(f"gmapping parameter '{name}' must be a number, got {value!r}")
                kwargs[name] = float(value)
            elif isinstance(default, int):
                if isinstance(value, float) and value.is_integer():
                    value = int(value)
                if isinstance(value, bool) or not isinstance(value, int):
                    raise ValueError(f"gmapping parameter '{name}' must be an integer, got {value!r}")
                kwargs[name] = value
            else:
                if isinstance(value, bool) and name == "inverted_laser":
                    value = "true" if value else "false"
                kwargs[name] = value
        return cls(**kwargs)

    def to_dict(self) -> Dict[str, Any]:
        """Return {ros_param_name: value}; the inverse of `from_dict`."""
        return dataclasses.asdict(self)


def _is_finite_number(value: Any) -> bool:
    return (not isinstance(value, bool) and isinstance(value, (int, float))
            and math.isfinite(value))
