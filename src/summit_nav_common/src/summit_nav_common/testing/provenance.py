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
