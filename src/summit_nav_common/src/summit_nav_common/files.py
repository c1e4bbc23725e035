"""Files: reading a YAML file with errors that name it, and writing files atomically.

``load_yaml`` turns the three ways a YAML file can be unusable (it cannot be opened, it
is not UTF-8 text, it does not parse) into the caller's own error type, with the file's
name and the fault in the message.

``write_atomic``: a reader sees the old file or the new one, never half of one. The bytes
go to a temporary file in the same folder, are flushed to disk, and the file is renamed
over the target (a rename within one file system is atomic on POSIX). On failure the
temporary file is removed and the target is left as it was.
"""
import os
import tempfile

import yaml


def load_yaml(path, error=ValueError, what=None):
    """The document in the YAML file at path (any YAML value; None for an empty file).

    Raises error (an exception class taking one message) when the file cannot be read,
    is not UTF-8 or is malformed YAML; the message starts with "<what> <path>: " (or
    "<path>: " without what), e.g. "waypoint file w.yaml: malformed YAML (...)". What the
    document must hold is the caller's to check.
    """
    label = f"{what} {path}" if what else str(path)
    try:
        with open(path, encoding="utf-8") as f:
            return yaml.safe_load(f)
    except OSError as e:
        raise error(f"{label}: cannot read it ({e.strerror or e})") from None
    except UnicodeDecodeError as e:
        raise error(f"{label}: not UTF-8 text ({e.reason} at byte {e.start})") from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" from line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e)
        raise error(f"{label}: malformed YAML (not YAML{where}): {problem}") from None


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
