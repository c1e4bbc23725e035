"""A KartoMapper's pose graph, scans and laser geometry in one file, and back.

Format: a NumPy .npz archive (no pickled objects) holding
    magic        "karto_pose_graph" (a foreign .npz is refused)
    version      FORMAT_VERSION
    checksum     SHA-256 over every other array's name, dtype, shape and bytes
    params       the KartoParams as JSON;  laser: the LaserGeometry as JSON
    stamps (N,), odom_poses (N, 3), poses (N, 3), ranges (N, n) float32
    edge_ij (E, 2), edge_kind (E,) (index into EDGE_KINDS), edge_z (E, 3), edge_info (E, 3, 3)
    running (R,) the running buffer; stats as JSON
Written to a temporary file beside the target, then renamed over it (os.replace), so a
reader never sees half a file. Loading re-derives each node's matching points from its
ranges. Anything wrong (not an npz, a missing array, another magic or version, a checksum
mismatch, inconsistent shapes) raises ValueError naming the file and the fault.
"""
import dataclasses
import hashlib
import io
import json
import os
import tempfile
import zipfile

import numpy as np

from .pose_graph import EDGE_KINDS, Node

MAGIC = "karto_pose_graph"
# 2: the three "variance" parameters stored as slam_karto's ROS values (their square roots);
# version 1 stored the variances themselves, and reads converted
FORMAT_VERSION = 2
READABLE_VERSIONS = (1, 2)
SQUARED_IN_V1 = ("distance_variance_penalty", "angle_variance_penalty", "loop_match_maximum_variance_coarse")
ARRAYS = ("stamps", "odom_poses", "poses", "ranges", "edge_ij", "edge_kind", "edge_z", "edge_info",
          "running", "params", "laser", "stats")


def _checksum(arrays) -> str:
    h = hashlib.sha256()
    for name in ARRAYS:
        a = np.ascontiguousarray(arrays[name])
        h.update(name.encode())
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def save_mapper(mapper, path: str) -> None:
    g = mapper.graph
    n_beams = int(mapper.laser.n_beams)
    edges = g.edges
    arrays = dict(
        stamps=np.array([n.stamp for n in g.nodes], float),
        odom_poses=np.array([n.odom_pose for n in g.nodes], float).reshape(-1, 3),
        poses=g.poses().astype(float),
        ranges=np.array([n.ranges for n in g.nodes], np.float32).reshape(-1, n_beams),
        edge_ij=np.array([(e.i, e.j) for e in edges], np.int64).reshape(-1, 2),
        edge_kind=np.array([EDGE_KINDS.index(e.kind) for e in edges], np.int64),
        edge_z=np.array([e.measurement for e in edges], float).reshape(-1, 3),
        edge_info=np.array([e.information for e in edges], float).reshape(-1, 3, 3),
        running=np.array(mapper._running, np.int64),
        params=np.array(json.dumps(dataclasses.asdict(mapper.params))),
        laser=np.array(json.dumps(dataclasses.asdict(mapper.laser))),
        stats=np.array(json.dumps(mapper.stats)),
    )
    arrays["magic"] = np.array(MAGIC)
    arrays["version"] = np.array(FORMAT_VERSION)
    arrays["checksum"] = np.array(_checksum(arrays))
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".karto-", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez_compressed(f, **arrays)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _read(path: str):
    try:
        with open(path, "rb") as f:
            blob = f.read()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read ({exc})") from exc
    try:
        with np.load(io.BytesIO(blob), allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (ValueError, OSError, zipfile.BadZipFile, EOFError, KeyError) as exc:
        raise ValueError(f"{path}: not a serialized karto map ({type(exc).__name__}: {exc})") from exc


def load_mapper(cls, path: str, params=None):
    from .mapper import KartoParams, LaserGeometry

    a = _read(path)
    if str(a.get("magic", "")) != MAGIC:
        raise ValueError(f"{path}: not a serialized karto map (magic {str(a.get('magic', None))!r})")
    version = int(a.get("version", -1))
    if version not in READABLE_VERSIONS:
        raise ValueError(f"{path}: format version {version}, this code reads {READABLE_VERSIONS}")
    missing = [k for k in ARRAYS + ("checksum",) if k not in a]
    if missing:
        raise ValueError(f"{path}: corrupt karto map, missing {missing}")
    if str(a["checksum"]) != _checksum(a):
        raise ValueError(f"{path}: corrupt karto map (checksum mismatch)")
    try:
        saved_dict = json.loads(str(a["params"]))
        if version == 1:
            saved_dict.update({k: float(saved_dict[k]) ** 0.5 for k in SQUARED_IN_V1 if k in saved_dict})
        saved = KartoParams(**saved_dict)
        laser_dict = json.loads(str(a["laser"]))
        laser_dict["mount"] = tuple(laser_dict["mount"])
        laser = LaserGeometry(**laser_dict)
        stats = json.loads(str(a["stats"]))
    except (TypeError, ValueError, KeyError) as exc:
        raise ValueError(f"{path}: corrupt karto map (parameters: {exc})") from exc
    n = len(a["stamps"])
    shapes_ok = (a["odom_poses"].shape == (n, 3) and a["poses"].shape == (n, 3)
                 and a["ranges"].shape == (n, int(laser.n_beams)) and a["edge_ij"].ndim == 2
                 and len(a["edge_kind"]) == len(a["edge_ij"]) == len(a["edge_z"]) == len(a["edge_info"])
                 and (len(a["edge_ij"]) == 0 or (a["edge_ij"].min() >= 0 and a["edge_ij"].max() < n))
                 and np.all((a["edge_kind"] >= 0) & (a["edge_kind"] < len(EDGE_KINDS))))
    if not shapes_ok:
        raise ValueError(f"{path}: corrupt karto map (inconsistent array shapes or indices)")
    mapper = cls(params if params is not None else saved, laser)
    for k in range(n):
        r = a["ranges"][k].astype(float)
        pts, ref = mapper._points_and_reference(r)
        mapper.graph.add_node(Node(id=k, stamp=float(a["stamps"][k]), odom_pose=a["odom_poses"][k].copy(),
                                   pose=a["poses"][k].copy(), ranges=a["ranges"][k].copy(), points=pts,
                                   reference=ref,
                                   barycenter=pts.mean(axis=0) if len(pts) else np.zeros(2)))
    for (i, j), kind, z, info in zip(a["edge_ij"], a["edge_kind"], a["edge_z"], a["edge_info"]):
        mapper.graph.add_edge(int(i), int(j), EDGE_KINDS[int(kind)], z, information=info)
    mapper._running = [int(k) for k in a["running"] if 0 <= k < n]
    mapper.stats.update({k: v for k, v in stats.items() if k in mapper.stats})
    mapper.stats["nodes"] = n
    return mapper
