"""summit_nav_common.testing.roslaunch_session: a benchmark stopped with `kill PID` stops what it started.

The live benchmarks run each pair or seed in a child process that holds a ROS graph
(roslaunch, the node under test) in with-blocks and finally clauses. Regression: killing
bench_move_base_live.py's parent left the child's roslaunch, simulator and move_base
running (SIGTERM ended the parent at once, and subprocess.run then SIGKILLed the child,
so no cleanup ran anywhere)."""
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

CHILD = textwrap.dedent("""
    import time
    from summit_nav_common.testing.roslaunch_session import exit_on_sigterm
    exit_on_sigterm()
    try:
        open({ready!r}, "w").close()
        time.sleep(60)
    finally:
        open({cleaned!r}, "w").close()   # stands for stopping the graph
""")

PARENTS = {
    # bench_slam_bag.py, bench_move_base_live.py
    "child_result": textwrap.dedent("""
        import sys
        from summit_nav_common.testing.roslaunch_session import child_result, exit_on_sigterm
        exit_on_sigterm()
        child_result([sys.executable, {child!r}])
    """),
    # bench_amcl_node.py and bench_stack_cpu.py (profile_node.run_child): killing them left
    # the run's roslaunch, amcl or move_base running (session 28)
    "profile_node.run_child": textwrap.dedent("""
        import sys
        from summit_nav_common.testing import profile_node
        from summit_nav_common.testing.roslaunch_session import exit_on_sigterm
        exit_on_sigterm()
        profile_node.run_child([sys.executable, {child!r}], 0)
    """),
}


def _wait_for(path, timeout=20.0):
    end = time.monotonic() + timeout
    while not os.path.exists(path):
        assert time.monotonic() < end, f"{path} never appeared"
        time.sleep(0.05)


@pytest.mark.parametrize("runner", sorted(PARENTS))
def test_killing_the_parent_lets_the_child_run_its_cleanup(tmp_path, runner):
    ready, cleaned = str(tmp_path / "ready"), str(tmp_path / "cleaned")
    child = tmp_path / "child.py"
    child.write_text(CHILD.format(ready=ready, cleaned=cleaned))
    parent = tmp_path / "parent.py"
    parent.write_text(PARENTS[runner].format(child=str(child)))
    proc = subprocess.Popen([sys.executable, str(parent)])
    try:
        _wait_for(ready)
        assert not os.path.exists(cleaned)
        os.kill(proc.pid, signal.SIGTERM)
        assert proc.wait(30) == 128 + signal.SIGTERM
        _wait_for(cleaned, timeout=5.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_a_wait_names_the_process_that_ended_its_exit_status_and_its_last_lines(tmp_path):
    from summit_nav_common.testing.roslaunch_session import Watched, wait_for
    log = tmp_path / "node.log"
    with open(log, "w") as out:
        proc = subprocess.Popen([sys.executable, "-c", "print('bad parameter: particles'); raise SystemExit(3)"],
                                stdout=out, stderr=subprocess.STDOUT)
    proc.wait()
    with pytest.raises(RuntimeError) as err:
        wait_for(lambda: False, 30.0, "the first scan", [Watched.process("slam_gmapping", proc, str(log))])
    text = str(err.value)
    assert text.startswith("slam_gmapping ended (exit status 3) while waiting for the first scan; last lines of ")
    assert text.endswith("bad parameter: particles\n")
