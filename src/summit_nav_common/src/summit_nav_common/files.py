"""Writing files atomically: a reader sees the old file or the new one, never half of one.

The bytes go to a temporary file in the same folder, are flushed to disk, and the file is
renamed over the target (a rename within one file system is atomic on POSIX). On failure
the temporary file is removed and the target is left as it was.
"""
import os
import tempfile


def write_atomic(path, data):
    """Write data (str: UTF-8 text, or bytes) to path atomically. Raises OSError (the
    caller names its own error) when the folder is missing or not writable."""
    path = os.path.abspath(os.path.expanduser(str(path)))
    payload = data.encode() if isinstance(data, str) else bytes(data)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp",
                               dir=os.path.dirname(path))
    try:
        # mkstemp makes the file 0600; give it the mode a plain open() would (0666 & ~umask).
        umask = os.umask(0)
        os.umask(umask)
        os.fchmod(fd, 0o666 & ~umask)
        with os.fdopen(fd, "wb") as f:
            f.write(payload)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
