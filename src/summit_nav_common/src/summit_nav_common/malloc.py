"""glibc's allocator set for a node whose threads churn large NumPy arrays.

Why: glibc gives each thread that allocates its own arena (up to 8 per core) and keeps
what is freed in it for reuse, and after a large block is freed it raises its mmap
threshold (up to 32 MB), so later large arrays come from the heap and stay there. A
node like move_base (30 threads: rospy's receivers, the costmaps' updates, the planner,
the control loop), each thread allocating arrays of the costmap's size every cycle,
then holds tens of MB it no longer uses (issue 43: each node at Python's floor plus the
real node's memory). ``limit_arenas`` caps the arenas and fixes the mmap threshold, so
an array above it is returned to the system when freed. Only where glibc is the C
library; elsewhere it does nothing and says so.

The price: every block above the mmap threshold, and every heap top trimmed, is mapped
and zeroed again by the kernel (a minor page fault per 4 KiB page) the next time it is
needed. A control loop that allocates its working arrays each cycle must therefore keep
them below the mmap threshold (DWA evaluates its samples in blocks for this), and the
heap keeps up to `trim_threshold` free at its top: DWA's cycle frees about 2 MB there,
and at the 1 MiB once set here the kernel took 600 faults a cycle to give it back.
bench_stack_cpu.py reports each node's minor faults per simulated second.
"""
import ctypes
import ctypes.util

M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
M_ARENA_MAX = -8


def limit_arenas(arenas=2, mmap_threshold=256 * 1024, trim_threshold=4 * 1024 * 1024):
    """Cap glibc's malloc arenas at `arenas`, hand blocks of `mmap_threshold` bytes or more
    to mmap (fixed, not raised after a free) and trim the heap's top above
    `trim_threshold` bytes. Call before the node starts its threads. Returns '' when
    set, else why not (for the node's log)."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return f"malloc settings left at their defaults: no glibc mallopt in {name!r}"
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    failed = [what for what, (param, value) in {
        "arena_max": (M_ARENA_MAX, arenas), "mmap_threshold": (M_MMAP_THRESHOLD, mmap_threshold),
        "trim_threshold": (M_TRIM_THRESHOLD, trim_threshold)}.items() if mallopt(param, value) != 1]
    return f"mallopt refused {', '.join(failed)}" if failed else ""
