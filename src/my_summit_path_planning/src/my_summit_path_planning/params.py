"""Typed configs from move_base's parameter namespace, with clear errors.

Reference: the parameter pages of move_base, costmap_2d, navfn and dwa_local_planner
(wiki.ros.org). move_base's own parameters sit at ~, costmap_2d's under ~global_costmap
and ~local_costmap, each plugin's under its own namespace (~NavfnROS, ~DWAPlannerROS,
~<recovery name>); every one is optional, with the real node's default. The course's
file layout (load_move_base_params): costmap_common_params.yaml is loaded into both
costmap namespaces.

Each parameter is declared once, in its dataclass, with type, unit and default; ranges
and old names are added where the dataclass is read (param_reader.Schema.of). A value
of the wrong type raises ParamError naming the file section, the parameter and what is
allowed. A name no dataclass has is left unread, as the real nodes leave it, and
reported in the config's notes for the node to log once (param_reader's notes).
DWA's renamed parameters (Kinetic names) are read as dwa_local_planner reads them.
"""
import os
from dataclasses import dataclass, field

from summit_nav_common.files import load_yaml

from .cost_values import FREE_SPACE, NO_INFORMATION
from . import costmap_params
from .costmap import Costmap2D, CostmapError, Footprint, LayeredCostmap
from .dwa import DWAConfig
from .navfn import NavfnConfig
from .param_reader import INVALID, ParamError, Schema

CONFIG_FILES = ("move_base_params.yaml", "costmap_common_params.yaml",
                "global_costmap_params.yaml", "local_costmap_params.yaml",
                "navfn_global_planner_params.yaml", "dwa_local_planner_params.yaml",
                "base_local_planner_params.yaml")

# dwa_local_planner's renamed parameters, old -> new. DWAPlannerROS::initialize warns for
# each old name present (nav_core::warnRenamedParameter: "will not load properly") and
# reads only the new ones; so does ours. Other old names (base_local_planner's acc_lim_th,
# vtheta_samples) it neither reads nor names: ours notes them as unread.
DWA_RENAMED = {"max_trans_vel": "max_vel_trans", "min_trans_vel": "min_vel_trans",
               "max_rot_vel": "max_vel_theta", "min_rot_vel": "min_vel_theta",
               "acc_limit_trans": "acc_lim_trans", "rot_stopped_vel": "theta_stopped_vel"}


@dataclass
class MoveBaseConfig:
    """move_base's own parameters, with the real node's defaults (wiki.ros.org/move_base)."""

    base_global_planner: str = "navfn/NavfnROS"
    base_local_planner: str = "base_local_planner/TrajectoryPlannerROS"
    recovery_behaviors: list = None        # None: move_base's default sequence
    controller_frequency: float = 20.0     # [Hz]
    planner_patience: float = 5.0          # [s]
    controller_patience: float = 15.0      # [s]
    conservative_reset_dist: float = 3.0   # [m]
    recovery_behavior_enabled: bool = True
    clearing_rotation_allowed: bool = True
    shutdown_costmaps: bool = False        # accepted; costmaps always run (logged as ignored)
    oscillation_timeout: float = 0.0       # [s] 0 = off
    oscillation_distance: float = 0.5      # [m]
    planner_frequency: float = 0.0         # [Hz] 0 = plan only on new goals
    max_planning_retries: int = -1         # -1 = unlimited
    make_plan_clear_costmap: bool = True   # ~make_plan plans as if the robot's circumscribed square were free
    make_plan_add_unreachable_goal: bool = True  # ~make_plan appends the goal to a path that ends short of it
    clearing_radius: float = None          # [m] ~make_plan's free square half-side; None: local_costmap/circumscribed_radius
    # ours: a folder; each time the local planner finds no valid command for
    # controller_patience, the controller's inputs (local costmap, pose, velocity, planner
    # state) are pickled there for an offline replay (at most DEBUG_DUMPS per run). Empty: off.
    debug_dump_dir: str = ""




@dataclass
class CostmapConfig:
    """costmap_2d's parameters for one costmap (after merging the common file)."""

    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    transform_tolerance: float = 0.2       # [s]
    update_frequency: float = 5.0          # [Hz]
    publish_frequency: float = 0.0         # [Hz]
    # Pre-Hydro flags (costmap_params): without a plugins list they choose the layers
    # (static_map: a static layer; map_type voxel: a voxel layer); beside one, unused.
    static_map: bool = True
    map_type: str = "costmap"              # "voxel" or "costmap"; absent: an obstacle layer
    rolling_window: bool = False
    always_send_full_costmap: bool = False
    track_unknown_space: bool = False
    width: float = 10.0                    # [m]
    height: float = 10.0                   # [m]
    resolution: float = 0.05               # [m/cell]
    origin_x: float = 0.0                  # [m]
    origin_y: float = 0.0                  # [m]
    footprint: object = None               # [[x, y], ...] [m] or its string
    robot_radius: float = 0.46             # [m] used when footprint is unset
    # Not costmap_2d's (it computes the radius from the footprint): move_base reads
    # ~local_costmap/circumscribed_radius for aggressive_reset (4 x) and clearing_radius.
    circumscribed_radius: float = 0.46     # [m]
    footprint_padding: float = 0.01        # [m]
    plugins: list = field(default_factory=list)
    layer_params: dict = field(default_factory=dict)  # {layer name: {param: value}}
    # Not parameters: costmap_2d's warnings about this namespace (the pre-Hydro layout,
    # keys that are ignored), for the node to log once.
    notes: list = field(default_factory=list)


# move_base parameters the real node reads and this one accepts without acting on them:
# the one value that matches what this node does; another is noted as ignored (INVALID).
MOVE_BASE_SCHEMA = Schema.of(MoveBaseConfig, shutdown_costmaps=dict(
    choices=(False,), fallback=True, note="parameter {name} is accepted but ignored by this move_base "
                                          "(its costmaps always run)"))
COSTMAP_SCHEMA = Schema.of(CostmapConfig, internal=("layer_params", "notes"),
                           **{k: dict(lo=0.0, lo_open=True) for k in ("resolution", "width", "height")})
# dwa_local_planner's dynamic_reconfigure raises a sample count below the .cfg's minimum, 1
_SAMPLES = dict(lo=1, clamp=True, note="{where}: '{name}' {value} raised to 1, its least value "
                                       "(dwa_local_planner's dynamic_reconfigure clamps it the same way)")
_DWA_FIELDS = {k: dict(lo=0, lo_open=True) for k in ("controller_frequency", "sim_time", "sim_granularity",
                                                      "angular_sim_granularity", "max_vel_theta", "acc_lim_x",
                                                      "acc_lim_theta")}
_DWA_FIELDS.update({k: _SAMPLES for k in ("vx_samples", "vy_samples", "vth_samples")})
for _old, _new in DWA_RENAMED.items():
    _DWA_FIELDS[_new] = dict(_DWA_FIELDS.get(_new, {}), renamed=(_old,))
DWA_SCHEMA = Schema.of(DWAConfig, **_DWA_FIELDS)
NAVFN_SCHEMA = Schema.of(NavfnConfig, default_tolerance=dict(lo=0.0))


def dwa_config(params, where="DWAPlannerROS", notes=None, note_where=None):
    """DWAConfig from the DWAPlannerROS dict, checked. notes (a list): the real node's
    warning for each renamed name (not read), one per other name it does not read
    (prefixed with note_where, default where), sample counts raised to 1."""
    r = DWA_SCHEMA.read(params, where, note_where)
    if notes is not None:
        notes += r.notes
    cfg = DWAConfig(**r.values)
    if cfg.min_vel_x > cfg.max_vel_x or cfg.min_vel_y > cfg.max_vel_y:
        raise ParamError(f"{where}: min_vel_x/y must not exceed max_vel_x/y")
    return cfg


def navfn_config(params, where="NavfnROS", notes=None, note_where=None):
    """NavfnConfig from the NavfnROS dict, checked; notes (a list): one warning per name
    it does not read (prefixed with note_where, default where)."""
    r = NAVFN_SCHEMA.read(params, where, note_where)
    if notes is not None:
        notes += r.notes
    return NavfnConfig(**r.values)


def costmap_config(params, where):
    """CostmapConfig from one costmap namespace; layer namespaces go to layer_params.

    A namespace without ``plugins`` (costmap_2d's pre-Hydro layout) is translated to
    plugins first, and top-level layer keys are copied into their layers, as
    costmap_2d does (costmap_params.to_plugin_layout); its warnings go to ``notes``.
    """
    params = dict(params or {})
    try:
        params, notes = costmap_params.to_plugin_layout(params)
    except costmap_params.PreHydroError as e:
        raise ParamError(f"{where}: {e}") from None
    plugins = params.get("plugins", [])
    if not isinstance(plugins, list):
        raise ParamError(f"{where}: 'plugins' must be a list of {{name, type}}")
    layer_names = []
    for i, p in enumerate(plugins):
        if not isinstance(p, dict) or not isinstance(p.get("name"), str) or not isinstance(p.get("type"), str):
            raise ParamError(f"{where}: plugins[{i}] must have string 'name' and 'type', got {p!r}")
        layer_names.append(p["name"])
    # Layer namespaces of the common file are kept even when this costmap does not use them.
    layer_params = {k: v for k, v in params.items() if isinstance(v, dict)}
    rest = {k: v for k, v in params.items() if not isinstance(v, dict)}
    # its notes are logged with the costmap's name in front (LayeredCostmap.warn_once)
    r = COSTMAP_SCHEMA.read(rest, where, note_where="")
    return CostmapConfig(**r.values, layer_params=layer_params, notes=notes + r.notes)


def build_costmap(cfg, where="costmap", log=None):
    """A LayeredCostmap from a CostmapConfig (layers from its plugins list).

    log: called once with each warning (the config's notes, then the layers' own, e.g.
    a parameter with no meaning in 2D); default: this package's Python logger.
    """
    try:
        fp = Footprint.from_params(cfg.footprint, cfg.robot_radius, cfg.footprint_padding)
        default = NO_INFORMATION if cfg.track_unknown_space else FREE_SPACE
        nx = max(1, int(round(cfg.width / cfg.resolution)))
        ny = max(1, int(round(cfg.height / cfg.resolution)))
        master = Costmap2D(nx, ny, cfg.resolution, cfg.origin_x, cfg.origin_y, default)
        lc = LayeredCostmap(master, fp, rolling_window=cfg.rolling_window, log=log, name=where)
        for note in cfg.notes:
            lc.warn_once(note)
        return lc.add_plugins(cfg.plugins, cfg.layer_params)
    except CostmapError as e:
        raise ParamError(f"{where}: {e}") from None


@dataclass
class MoveBaseParams:
    """Everything move_base reads, typed: its own parameters, its two costmaps, and every
    other sub-namespace as a dict (the planners' and the recovery behaviours' own
    namespaces, read by each plugin; see plugins.py)."""

    move_base: MoveBaseConfig
    global_costmap: CostmapConfig
    local_costmap: CostmapConfig
    namespaces: dict = field(default_factory=dict)   # {name: {param: value}}
    ignored: tuple = ()      # parameters given a value asking for what this node does not do (in notes too)
    notes: tuple = ()        # param_reader Notes about move_base's own namespace, for the node to log once

    def namespace(self, name):
        """The parameters under ~name ({} when missing: the plugin's defaults)."""
        return dict(self.namespaces.get(name) or {})

    @property
    def clearing_radius(self):
        """~clearing_radius [m] (~make_plan's free square), by default move_base's
        ~local_costmap/circumscribed_radius."""
        c = self.move_base.clearing_radius
        return self.local_costmap.circumscribed_radius if c is None else c

    @property
    def navfn(self):
        """NavfnConfig of ~NavfnROS."""
        return navfn_config(self.namespace("NavfnROS"), "NavfnROS")

    @property
    def dwa(self):
        """DWAConfig of ~DWAPlannerROS."""
        return dwa_config(self.namespace("DWAPlannerROS"), "DWAPlannerROS")


def move_base_params(ns, where="move_base"):
    """MoveBaseParams from move_base's private namespace as a dict (what
    rospy.get_param("~") returns). Every parameter is optional: a missing costmap or
    plugin namespace means its defaults, as in the real move_base; a name move_base does
    not read is left unread and noted. ParamError naming the parameter for a wrong type."""
    if ns is None:
        ns = {}
    if not isinstance(ns, dict):
        raise ParamError(f"{where}: expected a namespace of parameters, got {ns!r}")
    own = {k: v for k, v in ns.items() if not isinstance(v, dict)}
    subs = {k: v for k, v in ns.items() if isinstance(v, dict)}
    r = MOVE_BASE_SCHEMA.read(own, where, note_where="")   # notes logged as "move_base: ..."
    mb = MoveBaseConfig(**r.values)
    costmaps = {name: costmap_config(subs.pop(name, {}), f"{where}/{name}")
                for name in ("global_costmap", "local_costmap")}
    return MoveBaseParams(move_base=mb, namespaces=subs,
                          ignored=tuple(n.param for n in r.notes if n.kind == INVALID),
                          notes=tuple(r.notes), **costmaps)


def _read(path):
    doc = load_yaml(path, ParamError)
    if doc is None:
        return {}
    if not isinstance(doc, dict):
        raise ParamError(f"{path}: expected a mapping of parameters")
    return doc


def load_move_base_params(config_dir):
    """Read the course's YAML files (CONFIG_FILES) from config_dir into move_base's namespace, as
    move_base.launch loads them (the common file into both costmaps), then
    move_base_params."""
    docs = {}
    for name in CONFIG_FILES:
        path = os.path.join(config_dir, name)
        if not os.path.isfile(path):
            raise ParamError(f"{path}: missing (expected the files {CONFIG_FILES})")
        docs[name] = _read(path)
    common = docs["costmap_common_params.yaml"]
    ns = dict(docs["move_base_params.yaml"])
    for name in ("global_costmap", "local_costmap"):
        ns[name] = _deep_merge(ns.get(name) or {}, common)
    for name in CONFIG_FILES[2:]:
        ns = _deep_merge(ns, docs[name])
    return move_base_params(ns, os.path.basename(os.path.normpath(config_dir)))


def _deep_merge(base, over):
    out = dict(base)
    for k, v in (over or {}).items():
        out[k] = _deep_merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out
