"""No test, script, node or tool changes Python's module search path itself (issue 43).

Shared test and benchmark helpers are importable packages (summit_nav_common.testing, a
package's own library); a script or a rostest node imports its siblings (its folder is on
the path when it runs); tests import tools/ and the benchmark scripts they test through
tests/pytest.ini's pythonpath. About 70 path insertions once let tests, rostest nodes,
benchmark scripts and tools reach into each other's folders.
"""
import os
import re

WS = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROOTS = ("src", "tools", "tests")
SKIP_DIRS = {"__pycache__", "build", "devel", "install", ".git"}
# insert, append or extend on sys.path, += or a slice assigned to it, site.addsitedir; also
# inside strings (code a test hands to a child interpreter)
PATH_CHANGE = re.compile(r"\bsys\s*\.\s*path\s*(\.\s*(insert|append|extend)\b|\+=|\[[^\]]*\]\s*=(?!=))"
                         r"|\bsite\s*\.\s*addsitedir\b")


def python_sources():
    for root in ROOTS:
        for folder, dirs, files in os.walk(os.path.join(WS, root)):
            dirs[:] = [d for d in dirs if d not in SKIP_DIRS]
            for name in files:
                path = os.path.join(folder, name)
                if name.endswith(".py"):
                    yield path
                elif "." not in name:   # nodes/ and scripts/ executables without a suffix
                    with open(path, "rb") as f:
                        first = f.readline()
                    if first.startswith(b"#!") and b"python" in first:
                        yield path


def test_the_pattern_finds_each_kind_of_path_change():
    for line in ("sys.path.insert(0, HERE)", "sys.path.append(d)", "sys.path.extend([d])", "sys.path += [d]",
                 "sys.path[:0] = [d]", "site.addsitedir(d)", 'code = "import sys; sys.path.insert(0, x)"'):
        assert PATH_CHANGE.search(line), line
    for line in ("print(sys.path)", "if d in sys.path:", "sys.path[0] == HERE"):
        assert not PATH_CHANGE.search(line), line


def test_no_source_changes_the_module_search_path():
    found = []
    for path in python_sources():
        if os.path.samefile(path, __file__):   # the examples above
            continue
        with open(path, encoding="utf-8", errors="replace") as f:
            for n, line in enumerate(f, 1):
                if PATH_CHANGE.search(line):
                    found.append(f"{os.path.relpath(path, WS)}:{n}: {line.strip()}")
    assert not found, ("import shared helpers from a package (summit_nav_common.testing, the package's "
                       "library) instead of changing sys.path (docs/testing.md):\n  " + "\n  ".join(found))
