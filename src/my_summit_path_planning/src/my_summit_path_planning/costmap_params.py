"""costmap_2d's two parameter layouts: the plugin layout and the pre-Hydro one.

Reference: costmap_2d's Costmap2DROS (``costmap_2d_ros.cpp``: loadOldParameters,
copyParentParameters, warnForOldParameters) and wiki.ros.org/costmap_2d
("Hydro and later releases use plugins ... if no plugins are specified, the old
parameters are converted").

A costmap namespace without a ``plugins`` list is in the pre-Hydro layout (Fuerte and
Groovy, still used by navigation_tutorials' navigation_stage files). costmap_2d turns
it into plugins, and so does ``pre_hydro_to_plugins``:

  static_layer     costmap_2d::StaticLayer, only when ``static_map`` is true; takes
                   map_topic, unknown_cost_value, lethal_cost_threshold and a copy of
                   track_unknown_space
  obstacle_layer   costmap_2d::VoxelLayer when ``map_type`` is ``voxel`` (then takes
                   origin_z, z_resolution, z_voxels, mark_threshold, unknown_threshold,
                   publish_voxel_map), else costmap_2d::ObstacleLayer; takes
                   max_obstacle_height, raytrace_range, obstacle_range,
                   track_unknown_space, observation_sources and each source's namespace
  inflation_layer  costmap_2d::InflationLayer; takes cost_scaling_factor, inflation_radius

A moved key leaves the top level. In either layout, ``copy_parent_params`` then copies
what is still at the top level into the layers of the matching type, overriding the
layer's own value, as copyParentParameters does. Everything here works on plain dicts:
no ROS.
"""
from .param_reader import RENAMED, UNREAD, Note

STATIC_LAYER = "static_layer"
OBSTACLE_LAYER = "obstacle_layer"
INFLATION_LAYER = "inflation_layer"

STATIC_TYPE = "costmap_2d::StaticLayer"
OBSTACLE_TYPE = "costmap_2d::ObstacleLayer"
VOXEL_TYPE = "costmap_2d::VoxelLayer"
INFLATION_TYPE = "costmap_2d::InflationLayer"

# costmap_2d's warnings, word for word (the costmap's name is put in front).
PRE_HYDRO_WARNING = 'Parameter "plugins" not provided, loading pre-Hydro parameters'
OLD_PARAM_WARNING = 'Pre-Hydro parameter "{}" unused since "plugins" is provided'

# The pre-Hydro flags that choose the layers; unused once "plugins" is given.
PRE_HYDRO_FLAGS = ("static_map", "map_type")
MAP_TYPES = ("voxel", "costmap")  # pre-Hydro costmap_2d's two kinds of costmap

# loadOldParameters: top-level key -> moved into the layer (and off the top level).
STATIC_MOVED = ("map_topic", "unknown_cost_value", "lethal_cost_threshold")
VOXEL_MOVED = ("origin_z", "z_resolution", "z_voxels", "mark_threshold", "unknown_threshold",
               "publish_voxel_map")
OBSTACLE_MOVED = ("max_obstacle_height", "raytrace_range", "obstacle_range", "track_unknown_space")
INFLATION_MOVED = ("cost_scaling_factor", "inflation_radius")

# copyParentParameters: the top-level keys each layer type copies into its namespace.
PARENT_KEYS = {
    STATIC_TYPE: STATIC_MOVED + ("track_unknown_space",),
    VOXEL_TYPE: VOXEL_MOVED,
    OBSTACLE_TYPE: OBSTACLE_MOVED,
    INFLATION_TYPE: INFLATION_MOVED,
}
# Keys the costmap itself reads at its top level too (kept there after copying).
COSTMAP_OWN = ("track_unknown_space",)
# Top-level keys that only a layer reads: at the top level and taken by no layer of the
# costmap, they are ignored (with a note), as costmap_2d leaves them unread.
LAYER_ONLY_KEYS = tuple(sorted({k for keys in PARENT_KEYS.values() for k in keys} - set(COSTMAP_OWN))
                        + ["observation_sources"])


class PreHydroError(ValueError):
    """A pre-Hydro costmap namespace that cannot be translated."""


def is_pre_hydro(params):
    """True when a costmap namespace has no ``plugins`` list (costmap_2d's test)."""
    return "plugins" not in (params or {})


def _move(src, dst, key):
    if key in src:
        dst[key] = src.pop(key)


def _layer_ns(ns, name):
    """The layer's namespace dict inside ns, created (or copied, so the input is kept)."""
    old = ns.get(name)
    if old is not None and not isinstance(old, dict):
        raise PreHydroError(f"'{name}' must be the {name} namespace (a mapping), got {old!r}")
    ns[name] = dict(old or {})
    return ns[name]


def pre_hydro_to_plugins(params):
    """Translate a pre-Hydro costmap namespace as costmap_2d's loadOldParameters does.

    params: the costmap's namespace (dict; no ``plugins``). Returns (plugins,
    namespace): plugins is [{name, type}, ...] in costmap_2d's order; namespace is the
    costmap's namespace after the move, each moved key under its layer's name and gone
    from the top level (``track_unknown_space`` is copied to the static layer and moved
    to the obstacle layer). The input is not modified. PreHydroError for a map_type
    other than voxel or costmap, or observation_sources that is not a string.
    """
    ns = dict(params or {})
    if "plugins" in ns:
        raise PreHydroError("'plugins' is given: this costmap is in the plugin layout")
    plugins = []
    static_map = ns.get("static_map", False)
    if not isinstance(static_map, bool):
        raise PreHydroError(f"'static_map' must be true or false, got {static_map!r}")
    if static_map:
        plugins.append({"name": STATIC_LAYER, "type": STATIC_TYPE})
        layer = _layer_ns(ns, STATIC_LAYER)
        for key in STATIC_MOVED:
            _move(ns, layer, key)
        if "track_unknown_space" in ns:
            layer["track_unknown_space"] = ns["track_unknown_space"]

    map_type = ns.get("map_type")
    if map_type is not None and map_type not in MAP_TYPES:
        raise PreHydroError(f"'map_type' must be one of {', '.join(MAP_TYPES)}, got {map_type!r}")
    obstacles = _layer_ns(ns, OBSTACLE_LAYER)
    if map_type == "voxel":
        plugins.append({"name": OBSTACLE_LAYER, "type": VOXEL_TYPE})
        for key in VOXEL_MOVED:
            _move(ns, obstacles, key)
    else:
        plugins.append({"name": OBSTACLE_LAYER, "type": OBSTACLE_TYPE})
    for key in OBSTACLE_MOVED:
        _move(ns, obstacles, key)
    sources = ns.get("observation_sources", "")
    if not isinstance(sources, str):
        raise PreHydroError(f"'observation_sources' must be a space-separated string of "
                            f"source names, got {sources!r}")
    for source in sources.split():
        _move(ns, obstacles, source)
    _move(ns, obstacles, "observation_sources")

    inflation = _layer_ns(ns, INFLATION_LAYER)
    for key in INFLATION_MOVED:
        _move(ns, inflation, key)
    plugins.append({"name": INFLATION_LAYER, "type": INFLATION_TYPE})
    return plugins, ns


def copy_parent_params(plugins, params):
    """Copy top-level keys into the layers that read them (costmap_2d's copyParentParameters).

    plugins: [{name, type}, ...]; params: the costmap's namespace. Each layer of a type
    in PARENT_KEYS gets the top-level value of each of its keys, over its own value.
    Returns (namespace, unused): the namespace with the copied keys gone from the top
    level (``track_unknown_space`` stays: the costmap reads it too) and the sorted
    LAYER_ONLY_KEYS found at the top level that no layer of this costmap took.
    """
    ns = dict(params or {})
    taken = set()
    for p in plugins:
        keys = [k for k in PARENT_KEYS.get(p.get("type"), ()) if k in ns]
        if not keys:
            continue
        layer = _layer_ns(ns, p["name"])
        for k in keys:
            layer[k] = ns[k]
            taken.add(k)
    unused = sorted(k for k in LAYER_ONLY_KEYS if k in ns and k not in taken)
    for k in taken | set(unused):
        if k not in COSTMAP_OWN:
            ns.pop(k)
    return ns, unused


def to_plugin_layout(params):
    """A costmap namespace in either layout -> (namespace with ``plugins``, notes).

    notes: param_reader Notes, the warnings costmap_2d gives for this namespace (without
    the costmap's name): PRE_HYDRO_WARNING for the pre-Hydro layout, OLD_PARAM_WARNING for a
    pre-Hydro flag next to ``plugins``, and one note per top-level layer key that no
    layer takes (ignored).
    """
    params = dict(params or {})
    notes = []
    if is_pre_hydro(params):
        notes.append(Note(RENAMED, "plugins", PRE_HYDRO_WARNING))
        own = {k: params[k] for k in COSTMAP_OWN if k in params}
        plugins, params = pre_hydro_to_plugins(params)
        params["plugins"] = plugins
        params.update(own)  # Costmap2DROS reads these before loadOldParameters moves them
    else:
        notes += [Note(UNREAD, k, OLD_PARAM_WARNING.format(k)) for k in PRE_HYDRO_FLAGS if k in params]
    plugins = params["plugins"] if isinstance(params["plugins"], list) else []
    params, unused = copy_parent_params([p for p in plugins if isinstance(p, dict)], params)
    notes += [Note(UNREAD, k, f"parameter '{k}' at the costmap's top level is read by no layer of this "
                              f"costmap; ignored") for k in unused]
    return params, notes
