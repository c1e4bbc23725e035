#!/usr/bin/python3
"""Install the workspace's system packages (`make setup`).

Reads docker/packages.txt (the one list, shared with docker/Dockerfile): section
[common] always, then [noetic] when /opt/ros/noetic exists, else [debian]. Asks dpkg
first, so it is quick when everything is there; otherwise runs apt-get update once and
apt-get install (through sudo when not root).
"""
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
LIST = os.path.join(HERE, "..", "docker", "packages.txt")


def read_sections(path):
    """Return {section: [package, ...]} from an INI-like list file."""
    sections, current = {}, None
    with open(path) as f:
        for raw in f:
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            if line.startswith("[") and line.endswith("]"):
                current = line[1:-1]
                sections[current] = []
            elif current is None:
                sys.exit(f"{path}: package '{line}' before any [section]")
            else:
                sections[current].append(line)
    return sections


def missing(packages):
    """Packages dpkg does not report as installed."""
    out = []
    for pkg in packages:
        r = subprocess.run(["dpkg-query", "-W", "-f=${Status}", pkg],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        if "install ok installed" not in r.stdout:
            out.append(pkg)
    return out


def main():
    sections = read_sections(LIST)
    ros = "noetic" if os.path.isdir("/opt/ros/noetic") else "debian"
    wanted = sections["common"] + sections[ros]
    todo = missing(wanted)
    if not todo:
        print(f"setup: all {len(wanted)} packages present ({ros} ROS)")
        return
    print(f"setup: installing {len(todo)} packages: {' '.join(todo)}")
    sudo = [] if os.geteuid() == 0 else ["sudo"]
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    subprocess.run(sudo + ["apt-get", "update"], check=True, env=env)
    subprocess.run(sudo + ["apt-get", "install", "-y", "--no-install-recommends"] + todo,
                   check=True, env=env)
    still = missing(wanted)
    if still:
        sys.exit(f"setup: still missing after apt-get install: {' '.join(still)}")


if __name__ == "__main__":
    main()
