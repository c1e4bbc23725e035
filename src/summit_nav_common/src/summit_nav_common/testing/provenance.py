"""Where a benchmark figure comes from: the workspace's commit (no rospy)."""
import subprocess

# Written by a benchmark run itself, so their changes do not make the checkout "dirty".
GENERATED = ("docs/bench.json", "docs/benchmarks.md", "README.md")


def git_commit(ws):
    """`git rev-parse --short HEAD` of the checkout at ws, plus "-dirty" when tracked files
    other than GENERATED differ from HEAD; None outside a git checkout."""
    try:
        head = subprocess.run(["git", "-C", ws, "rev-parse", "--short", "HEAD"], check=True,
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout.strip()
        status = subprocess.run(["git", "-C", ws, "status", "--porcelain", "--untracked-files=no", "--", "."]
                                + [f":(exclude){p}" for p in GENERATED], check=True,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("-dirty" if status.strip() else "")


def ros_package_of(executable):
    """Which ROS package an executable of a catkin workspace or install belongs to, so a
    benchmark names another node by its package, version and sources rather than by a
    path that exists on one machine:
    {"executable", "package", "version", "repository" (owner/name from package.xml's
    repository url, else None), "commit" (of a git checkout holding the package's
    sources, else None)}; None when the path is not <prefix>/{devel,install,...}/lib/<pkg>/<exe>
    or no package.xml of that name is found beside it."""
    import glob
    import os
    import re
    import xml.etree.ElementTree as ET

    executable = os.path.realpath(executable)
    lib = os.path.dirname(os.path.dirname(executable))
    package = os.path.basename(os.path.dirname(executable))
    if os.path.basename(lib) != "lib":
        return None
    prefix = os.path.dirname(lib)                       # devel/, install/ or /opt/ros/<distro>
    candidates = [os.path.join(prefix, "share", package, "package.xml")]
    workspace = os.path.dirname(prefix)
    for depth in ("*", "*/*", "*/*/*"):                 # a source space: src/<repo>/<pkg>/package.xml
        candidates += glob.glob(os.path.join(workspace, "src", depth, "package.xml"))
    for path in candidates:
        try:
            root = ET.parse(path).getroot()
        except (OSError, ET.ParseError):
            continue
        if (root.findtext("name") or "").strip() != package:
            continue
        urls = [u.text.strip() for u in root.findall("url") if u.text and u.get("type") == "repository"]
        m = re.search(r"github\.com[/:]([^/\s]+/[^/\s]+?)(?:\.git)?/?$", urls[0]) if urls else None
        commit = _checkout_commit(os.path.dirname(path), os.path.join(workspace, "src"))
        return {"executable": os.path.basename(executable), "package": package,
                "version": (root.findtext("version") or "").strip() or None,
                "repository": m.group(1) if m else (urls[0] if urls else None), "commit": commit}
    return None


def _checkout_commit(folder, within):
    """HEAD of the git checkout holding folder when that checkout lies inside `within`
    (a workspace's src/: not a repository that merely contains the whole workspace)."""
    import os
    try:
        top, head = subprocess.run(["git", "-C", folder, "rev-parse", "--show-toplevel", "HEAD"], check=True,
                                   stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout.split()
    except (OSError, ValueError, subprocess.CalledProcessError):
        return None
    within = os.path.realpath(within)
    return head if os.path.realpath(top).startswith(within + os.sep) else None
