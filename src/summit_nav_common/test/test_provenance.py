"""summit_nav_common.testing.provenance: the commit stamp and a peer node's package."""
import os
import subprocess

from summit_nav_common.testing.provenance import ros_package_of

PACKAGE_XML = """<?xml version="1.0"?>
<package format="2">
  <name>{name}</name>
  <version>{version}</version>
  {url}
</package>
"""


def _workspace(root, folder, name, version, url=""):
    """A catkin workspace with one package in src/<folder>/ and its executable in devel/lib."""
    pkg = root / "src" / folder
    pkg.mkdir(parents=True)
    (pkg / "package.xml").write_text(PACKAGE_XML.format(name=name, version=version, url=url))
    exe = root / "devel" / "lib" / name / "node_exe"
    exe.parent.mkdir(parents=True)
    exe.write_text("#!/bin/sh\n")
    return str(exe), pkg


def test_a_devel_space_executable_is_named_by_its_package_version_and_repository(tmp_path):
    exe, _ = _workspace(tmp_path, "navigation/move_base", "move_base", "1.17.3",
                        '<url type="repository">https://github.com/ros-planning/navigation.git</url>')
    assert ros_package_of(exe) == {"executable": "node_exe", "package": "move_base", "version": "1.17.3",
                                   "repository": "ros-planning/navigation", "commit": None}


def test_the_commit_of_a_checkout_holding_the_sources(tmp_path):
    exe, pkg = _workspace(tmp_path, "gmapping", "gmapping", "1.4.2")
    env = dict(os.environ, GIT_AUTHOR_NAME="t", GIT_AUTHOR_EMAIL="t@t", GIT_COMMITTER_NAME="t",
               GIT_COMMITTER_EMAIL="t@t")
    for cmd in (["init", "-q"], ["add", "-A"], ["commit", "-qm", "c"]):
        subprocess.run(["git", "-C", str(pkg), *cmd], check=True, env=env)
    head = subprocess.run(["git", "-C", str(pkg), "rev-parse", "HEAD"], check=True, stdout=subprocess.PIPE,
                          text=True).stdout.strip()
    got = ros_package_of(exe)
    assert got["package"] == "gmapping" and got["version"] == "1.4.2" and got["commit"] == head
    assert got["repository"] is None


def test_not_a_package_executable(tmp_path):
    loose = tmp_path / "bin" / "move_base"
    loose.parent.mkdir()
    loose.write_text("")
    assert ros_package_of(str(loose)) is None
    exe, _ = _workspace(tmp_path / "ws", "other", "other_name", "1.0.0")
    os.rename(os.path.dirname(exe), os.path.join(os.path.dirname(os.path.dirname(exe)), "not_there"))
    assert ros_package_of(os.path.join(os.path.dirname(os.path.dirname(exe)), "not_there", "node_exe")) is None
