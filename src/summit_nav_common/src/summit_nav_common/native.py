"""The workspace's kernels compiled ahead of time (csrc/, built by catkin), loaded with ctypes.

Why not numba: a process that imports numba carries LLVM, about 60 MB of RSS, for loops
that are a few dozen lines of C (issue 43: each node at Python's floor plus the real
node's memory). The C is compiled once at build time into ``libsummit_nav_kernels.so``
in the workspace's lib folder (devel/lib, or the install space's lib), found through
``LD_LIBRARY_PATH`` (setup.bash sets it) or ``CMAKE_PREFIX_PATH``; ctypes adds well under
1 MB. Each kernel has a NumPy/Python reference that stays its test oracle.

``library()`` returns the loaded library with its argument types declared;
``NativeError`` says which file was looked for where, and that ``make build`` builds it.
"""
import ctypes
import os

import numpy as np

LIB_NAME = "libsummit_nav_kernels.so"

_f64 = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
_f32 = np.ctypeslib.ndpointer(dtype=np.float32, flags="C_CONTIGUOUS")
_i64 = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")
_i32 = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
_u8 = np.ctypeslib.ndpointer(dtype=np.uint8, flags="C_CONTIGUOUS")
_int64 = ctypes.c_int64
_double = ctypes.c_double
_out_points = ctypes.POINTER(ctypes.POINTER(ctypes.c_double))   # double **: a malloc'd (n, 2) array
_out_int = ctypes.POINTER(ctypes.c_int)

# name: (restype, argtypes), as declared in csrc/*.c
SIGNATURES = {
    "snc_grid_csr": (_int64, [_f64, _u8, _i64, _int64, _int64, _i64, _i32, _f64]),
    "snc_reduced_weights": (None, [_i64, _i32, _f64, _f64, _int64, _f64]),
    "snc_dijkstra": (ctypes.c_int, [_i64, _i32, _f64, _int64, _int64, ctypes.c_double, _f64]),
    "snc_grid_dijkstra": (ctypes.c_int, [_f64, ctypes.c_void_p, _int64, _int64, _int64, ctypes.c_double, _f64]),
    # csrc/distance.c, interpolate.c, components.c (summit_nav_common.grid_kernels)
    "snc_edt": (ctypes.c_int, [_u8, _int64, _int64, _f32]),
    "snc_chamfer5_labels": (ctypes.c_int, [_u8, _int64, _int64, _f32, _i32]),
    "snc_remap_bilinear": (None, [_f32, _int64, _int64, _f32, _f32, _int64, ctypes.c_float, _f32]),
    "snc_upsample_linear": (None, [_f32, _int64, _int64, _int64, _f32, _f32]),
    "snc_label8": (_int64, [_u8, _int64, _int64, _i32]),
    # csrc/raytrace.c (the costmaps' clearing)
    "snc_fill_rays": (None, [_u8, _int64, _int64, ctypes.c_double, ctypes.c_double, _f64, _f64, _int64,
                             ctypes.c_double, ctypes.c_uint8]),
    # csrc/patch_grid.c (my_summit_mapping's grid and scan matcher)
    "snc_touched_patches": (None, [_int64, _i64, _i64, _int64, _int64, _int64, _int64, _u8]),
    "snc_trace_into": (None, [_f32, _int64, _i64, _int64, _int64, _int64, _i64, _i64, _f64, _u8, _int64,
                              ctypes.c_double, ctypes.c_double]),
    "snc_add_hits_into": (None, [_f32, _int64, _i64, _int64, _int64, _int64, _i64, _f64, _int64, ctypes.c_double,
                                 ctypes.c_double]),
    "snc_optimize": (None, [_f32, _int64] + [_i64] * 6 + [_f64, _int64, _f64, _f64, _f64, _int64, ctypes.c_double,
                                                  ctypes.c_double, _int64, ctypes.c_double, ctypes.c_double,
                                                  _int64, _f64, _int64, _int64, _f64, _f64]),
    "snc_likelihoods": (None, [_f32, _int64] + [_i64] * 6 + [_f64, _int64, _f64, _f64, _f64, _int64, ctypes.c_double,
                                                     ctypes.c_double, ctypes.c_double, _int64, ctypes.c_double,
                                                     _f64, _f64]),
    # csrc/correlation_grid.c (my_summit_mapping.karto.correlative_matcher)
    "snc_stamp_max": (None, [_u8, _i64, _int64, _u8, _int64, _int64]),
    "snc_box_max": (ctypes.c_int, [_u8, _int64, _int64, _int64, _u8]),
    "snc_correlate_sums": (None, [_u8, _i64, _int64, _int64, _i64, _int64, _i64]),
    # csrc/global_planner.c (my_summit_path_planning.global_planner)
    "snc_gp_expand": (ctypes.c_int, [_f64, _int64, _int64, _i64, _f64, _int64, _int64, _double, ctypes.c_int, _f64,
                                     ctypes.POINTER(_int64)]),
    "snc_gp_clear_endpoint": (None, [_f64, _int64, _int64, _f64, _int64, _int64, _int64, ctypes.c_int]),
    "snc_gp_gradient_path": (_int64, [_f64, _int64, _int64, _double, _double, _double, _double, _double, _int64,
                                      _out_points, _out_int]),
    "snc_gp_grid_path": (_int64, [_f64, _int64, _int64, _int64, _int64, _int64, _int64, _int64, _out_points,
                                  _out_int]),
    "snc_free": (None, [ctypes.c_void_p]),
    # csrc/footprint_cost.c, trajectory.c (my_summit_path_planning.footprint_cost, .trajectory_planner)
    "snc_outline_costs": (None, [_u8, _int64, _i64, _i64, _u8, _int64, _int64, _f64]),
    "snc_tp_wavefront": (ctypes.c_int, [_u8, _int64, _int64, _i64, _i64, _int64, _double, _f64]),
    "snc_tp_first_failure": (None, [_u8, _int64, _i64, _int64, _int64, _int64, _u8, _i64, _i64, _u8, _f64, _i64,
                                    _f64, _f64]),
}


class NativeError(RuntimeError):
    """The compiled kernels' library is missing or does not hold a kernel."""


def _candidates():
    dirs = [d for d in os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep) if d]
    dirs += [os.path.join(p, "lib") for p in os.environ.get("CMAKE_PREFIX_PATH", "").split(os.pathsep) if p]
    return [os.path.join(d, LIB_NAME) for d in dirs]


_lib = None


def library():
    """The kernels' library, loaded once, with every SIGNATURES entry declared."""
    global _lib
    if _lib is None:
        paths = _candidates()
        path = next((p for p in paths if os.path.isfile(p)), None)
        if path is None:
            raise NativeError(f"{LIB_NAME} not found in LD_LIBRARY_PATH or CMAKE_PREFIX_PATH/lib "
                              f"(looked in {len(paths)} folders); build the workspace (make build) "
                              "and source devel/setup.bash")
        lib = ctypes.CDLL(path)
        for name, (restype, argtypes) in SIGNATURES.items():
            try:
                fn = getattr(lib, name)
            except AttributeError as e:
                raise NativeError(f"{path} has no {name}: rebuild the workspace (make build)") from e
            fn.restype, fn.argtypes = restype, argtypes
        _lib = lib
    return _lib


def take_points(ptr, n, what):
    """The (n, 2) float64 points a kernel returned in a malloc'd buffer (ptr, n points),
    copied into a NumPy array; the buffer is freed. n < 0: the kernel ran out of memory
    (MemoryError naming `what`)."""
    if n < 0:
        raise MemoryError(f"{what}: out of memory")
    try:
        return np.ctypeslib.as_array(ptr, shape=(n, 2)).copy() if n else np.empty((0, 2))
    finally:
        library().snc_free(ptr)
