"""The course project rostest's load (rt_course_project.OneCore): a whole process tree,
every thread of it and what it starts later, confined to one CPU."""
import importlib.util
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))

# A parent with a second thread; on a line on stdin it starts a child (with its own
# thread) and prints the child's pid; both then sleep.
TREE = r"""
import subprocess, sys, threading, time
threading.Thread(target=time.sleep, args=(60,), daemon=True).start()
kids = []
for line in sys.stdin:
    kids.append(subprocess.Popen([sys.executable, "-c",
        "import threading, time; threading.Thread(target=time.sleep, args=(60,)).start(); time.sleep(60)"]))
    print(kids[-1].pid, flush=True)
"""


def _load():
    spec = importlib.util.spec_from_file_location("rt_course_project", os.path.join(HERE, "rt_course_project.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _threads_of(pid):
    return [int(t) for t in os.listdir(f"/proc/{pid}/task")]


def test_one_core_confines_the_tree_and_what_it_starts_later():
    rt = _load()
    root = subprocess.Popen([sys.executable, "-c", TREE], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        root.stdin.write("\n")
        root.stdin.flush()
        first = int(root.stdout.readline())
        time.sleep(0.3)     # the child's thread has started
        assert len(_threads_of(root.pid)) == 2 and len(_threads_of(first)) == 2
        core = rt.OneCore(root.pid)
        assert core.unconfined(), "nothing to confine yet: the test would prove nothing"
        with core:
            assert core.unconfined() == []
            for pid in (root.pid, first):
                assert all(os.sched_getaffinity(t) == {core.cpu} for t in _threads_of(pid))
            root.stdin.write("\n")      # a process started after confinement inherits it
            root.stdin.flush()
            later = int(root.stdout.readline())
            time.sleep(0.3)
            assert set(rt.process_tree(root.pid)) == {root.pid, first, later}
            assert all(os.sched_getaffinity(t) == {core.cpu} for t in _threads_of(later))
            assert core.unconfined() == []
            os.sched_setaffinity(first, os.sched_getaffinity(0))   # one thread escapes: it is named
            assert core.unconfined() == [(first, first)]
    finally:
        for pid in rt.process_tree(root.pid)[::-1]:
            try:
                os.kill(pid, 9)
            except ProcessLookupError:
                pass
        root.wait()
