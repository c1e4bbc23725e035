"""numba's njit when numba is installed, else a no-op decorator.

Compiled kernels (ray casting, the global planner's expansion) run as plain Python, with
identical results but slowly, where numba (Debian's python3-numba) is missing, so the
packages do not require it; the simulator, which needs the speed, declares it.
"""
try:
    from numba import njit
    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is absent
    HAVE_NUMBA = False

    def njit(*args, **kwargs):
        """Fallback: run the kernel as plain Python."""
        if len(args) == 1 and callable(args[0]):
            return args[0]
        return lambda f: f
