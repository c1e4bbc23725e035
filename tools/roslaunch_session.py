"""Start a roslaunch on a private ROS master and always stop it (demo, bench, frames).

    with RoslaunchSession(["summit_xl_sim", "tour.launch", "speed:=8"], log=path) as s:
        ...  # s.env has ROS_MASTER_URI; rospy in this process uses it when set before init

The launch runs in its own process group; on exit it gets SIGINT, then SIGKILL for the
group and for every process that was below it (roslaunch gives nodes their own sessions).
"""
import os
import signal
import socket
import subprocess
import time

import psutil


def free_port():
    """A TCP port that was free a moment ago."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop_process_tree(proc, grace=20.0):
    """Stop a subprocess started with start_new_session=True, and all below it.

    roslaunch starts each node in a session of its own, so a node that hangs on
    shutdown would survive a plain group kill: its PID is collected first and killed.
    A leader that has already ended still gets its group killed (what it left behind).
    Only these PIDs: never anything found by name.
    """
    if proc is None:
        return
    running = proc.poll() is None
    below = process_tree(proc.pid)[1:] if running else []
    if running:
        try:
            os.killpg(proc.pid, signal.SIGINT)
            proc.wait(timeout=grace)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    for p in below:
        try:
            p.kill()
        except psutil.NoSuchProcess:
            pass
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        pass


def process_tree(root):
    """psutil.Process of root (first) and of every process below it; [] if root is gone."""
    try:
        top = psutil.Process(root)
        return [top] + top.children(recursive=True)
    except psutil.NoSuchProcess:
        return []


class RoslaunchSession:
    """A roslaunch subprocess with its own master (port chosen here)."""

    def __init__(self, args, log=None, env=None):
        self.port = free_port()
        self.env = dict(env or os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{self.port}")
        self.args = ["roslaunch", "-p", str(self.port)] + list(args)
        self.log_path = log
        self.proc = None

    def __enter__(self):
        os.environ["ROS_MASTER_URI"] = self.env["ROS_MASTER_URI"]
        out = open(self.log_path, "w") if self.log_path else subprocess.DEVNULL
        self.proc = subprocess.Popen(self.args, stdout=out, stderr=subprocess.STDOUT, env=self.env,
                                     start_new_session=True)
        return self

    def alive(self):
        """True while roslaunch runs."""
        return self.proc is not None and self.proc.poll() is None

    def stop(self, grace=20.0):
        """SIGINT the group (roslaunch's clean shutdown), wait up to grace [s], then
        SIGKILL the group and every process that was below roslaunch."""
        stop_process_tree(self.proc, grace)

    def __exit__(self, *exc):
        self.stop()
        return False


def run_bounded(args, env, timeout):
    """Run a command in its own session, killing its whole tree after timeout [s].

    Returns (returncode, output); returncode is None when it was killed on timeout.
    """
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=env, start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
        return proc.returncode, out
    except subprocess.TimeoutExpired:
        stop_process_tree(proc, grace=5.0)
        out, _ = proc.communicate()
        return None, out
    finally:
        stop_process_tree(proc, grace=5.0)


def wait_for_sim_time_param(session, timeout=60.0):
    """Wait until the launch has set /use_sim_time true on its master, so that a rospy
    node initialised afterwards in this process runs on the simulator's /clock."""
    import rosgraph

    master = rosgraph.Master("/roslaunch_session", master_uri=session.env["ROS_MASTER_URI"])

    def set_true():
        try:
            return master.getParam("/use_sim_time") is True
        except Exception:  # master not up yet, or the param not set yet
            return False

    wait_for(set_true, timeout, "/use_sim_time on the launch's master", session, poll=0.1)


def wait_for(predicate, timeout, what, session=None, poll=0.05):
    """Wait until predicate() is true; RuntimeError naming `what` on timeout or launch death."""
    end = time.monotonic() + timeout
    while not predicate():
        if session is not None and not session.alive():
            raise RuntimeError(f"the launch ended while waiting for {what} (see {session.log_path})")
        if time.monotonic() > end:
            raise RuntimeError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(poll)
