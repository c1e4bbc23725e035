"""Start a roslaunch on a private ROS master and always stop it (demo, bench, frames).

    with RoslaunchSession(["summit_xl_sim", "tour.launch", "speed:=8"], log=path) as s:
        ...  # s.env has ROS_MASTER_URI; rospy in this process uses it when set before init

The launch runs in its own process group; on exit it gets SIGINT, then SIGKILL for the
group and for every process that was below it (roslaunch gives nodes their own sessions).
"""
import json
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


def cpu_seconds(pid, tid=None):
    """utime + stime [s] of a process (or of its thread tid), from /proc."""
    path = f"/proc/{pid}/stat" if tid is None else f"/proc/{pid}/task/{tid}/stat"
    with open(path) as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def minor_faults(pid):
    """Minor page faults of a process so far, from /proc: each is a fresh page the kernel
    maps and zeroes, the price of memory handed back to it and taken again."""
    with open(f"/proc/{pid}/stat") as f:
        return int(f.read().rsplit(")", 1)[1].split()[7])


def thread_cpu(pid):
    """{tid: CPU s} of every thread of the process."""
    out = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            out[int(tid)] = cpu_seconds(pid, tid)
        except OSError:   # the thread ended meanwhile
            pass
    return out


def peak_rss_mb(pid):
    """The process's peak resident memory (VmHWM) [MB]; nan when /proc has none."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def find_node_pid(launch_pid, name):
    """PID of the ROS node `name` (its __name:= argument) below the process launch_pid
    (a roslaunch), or None."""
    for p in psutil.Process(launch_pid).children(recursive=True):
        try:
            if f"__name:={name}" in p.cmdline():
                return p.pid
        except psutil.NoSuchProcess:
            continue
    return None


def check_node_args(node, setup):
    """ValueError naming the option when --node EXECUTABLE / --node-setup SETUP_BASH (a
    peer node run in ours' place, and the file its environment is sourced from) cannot be used."""
    if setup is not None and node is None:
        raise ValueError("--node-setup needs --node")
    if node is not None and not (os.path.isfile(node) and os.access(node, os.X_OK)):
        raise ValueError(f"--node {node}: not an executable file")
    if setup is not None and not os.path.isfile(setup):
        raise ValueError(f"--node-setup {setup}: no such file")


def sourced_env(setup, base, extend=False):
    """The environment (dict) a bash started with `base` has after sourcing `setup`
    (with extend: `source setup --extend`, a catkin workspace's setup.bash then adds its
    workspace to the one `base` has instead of replacing it)."""
    proc = subprocess.run(["bash", "-c", 'source "$0" "$@" >&2 && env -0', setup] + (["--extend"] if extend else []),
                          env=base, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if proc.returncode != 0:
        raise ValueError(f"--node-setup {setup}: sourcing it failed (exit status {proc.returncode}): "
                         f"{proc.stderr.decode(errors='replace')[-500:]}")
    return dict(item.split("=", 1) for item in proc.stdout.decode(errors="replace").split("\0") if "=" in item)


def process_tree(root):
    """psutil.Process of root (first) and of every process below it; [] if root is gone."""
    try:
        top = psutil.Process(root)
        return [top] + top.children(recursive=True)
    except psutil.NoSuchProcess:
        return []


class RoslaunchSession:
    """A roslaunch subprocess with its own master (port chosen here)."""
    name = "the launch"

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

    def status(self):
        """roslaunch's exit status, None while it runs or before it started."""
        return self.proc.returncode if self.proc is not None else None

    def stop(self, grace=20.0):
        """SIGINT the group (roslaunch's clean shutdown), wait up to grace [s], then
        SIGKILL the group and every process that was below roslaunch."""
        stop_process_tree(self.proc, grace)

    def __exit__(self, *exc):
        self.stop()
        return False


class Roscore:
    """A roscore on a free port of its own, answering when entered, always stopped.

        with Roscore(log=path, caller="/bench") as core:
            core.master.setParam(...)   # rosgraph.Master on it
            subprocess.run(cmd, env=core.env)   # core.env: env with its ROS_MASTER_URI

    RuntimeError naming the port (and its log) when it ends or does not answer
    within timeout [s wall].
    """
    name = "roscore"

    def __init__(self, log=None, env=None, timeout=60.0, caller="/roscore_client"):
        self.port = free_port()
        self.env = dict(env or os.environ, ROS_MASTER_URI=f"http://127.0.0.1:{self.port}")
        self.log_path, self.timeout, self.caller = log, timeout, caller
        self.proc = None
        self.master = None

    def start(self):
        """Start it and wait until it answers; returns self."""
        import rosgraph
        out = open(self.log_path, "w") if self.log_path else subprocess.DEVNULL
        try:
            self.proc = subprocess.Popen(["roscore", "-p", str(self.port)], stdout=out, stderr=subprocess.STDOUT,
                                         env=self.env, start_new_session=True)
        finally:
            if out is not subprocess.DEVNULL:
                out.close()
        self.master = rosgraph.Master(self.caller, master_uri=self.env["ROS_MASTER_URI"])
        try:
            wait_for(self._answers, self.timeout, f"roscore on port {self.port}", self)
        except RuntimeError:
            self.stop()
            raise
        return self

    def _answers(self):
        try:
            self.master.getPid()
            return True
        except Exception:  # not up yet
            return False

    def alive(self):
        """True while roscore runs."""
        return self.proc is not None and self.proc.poll() is None

    def status(self):
        """roscore's exit status, None while it runs or before it started."""
        return self.proc.returncode if self.proc is not None else None

    def stop(self, grace=20.0):
        stop_process_tree(self.proc, grace)

    __enter__ = start

    def __exit__(self, *exc):
        self.stop()
        return False


RESULT_PREFIX = "RESULT "   # the line a child run prints its JSON record on (child_result)


def print_result(record):
    """A child run's record, as the line child_result reads back."""
    print(RESULT_PREFIX + json.dumps(record), flush=True)


CHILD_STOP_GRACE = 60.0   # [s] for a child run to stop its graph (move_base 15 s, the launch 25 s at most)


def exit_on_sigterm():
    """Make SIGTERM end this process as Ctrl-C would, through its with-blocks and finally
    clauses, so that a benchmark stopped by `kill PID` stops the graph it started."""
    def _exit(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_IGN)   # once: a second kill must not cut the cleanup short
        raise SystemExit(128 + signum)
    signal.signal(signal.SIGTERM, _exit)


def run_child_process(cmd):
    """Run cmd (a child run of a benchmark script: rospy starts once per process, so each
    run has its own) to its end; -> (exit status, its output). Interrupted, the child has
    CHILD_STOP_GRACE to stop what it started before it is killed: after Ctrl-C (SIGINT
    reached it too, through the terminal's process group) it is only waited for;
    otherwise (SIGTERM after exit_on_sigterm, an error) it gets SIGTERM first."""
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) as proc:
        try:
            out, _ = proc.communicate()
        except BaseException as e:
            if not isinstance(e, KeyboardInterrupt):
                proc.terminate()
            try:
                proc.communicate(timeout=CHILD_STOP_GRACE)   # drained, so it cannot block on a full pipe
            except subprocess.TimeoutExpired:
                proc.kill()
            raise
    return proc.returncode, out


def child_result(cmd):
    """run_child_process(cmd) -> (record, None) from the child's last print_result line, or
    (None, what went wrong: its exit status and the tail of its output)."""
    returncode, out = run_child_process(cmd)
    lines = [line for line in out.splitlines() if line.startswith(RESULT_PREFIX)]
    if returncode != 0 or not lines:
        return None, f"exit status {returncode}:\n{out[-4000:]}"
    return json.loads(lines[-1][len(RESULT_PREFIX):]), None


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


class Watched:
    """A process a wait keeps an eye on: name, alive() -> bool, log_path (its output) and
    status() -> its exit status or None. RoslaunchSession and Roscore have the first three."""

    def __init__(self, name, alive, log_path=None, status=None):
        self.name, self.alive, self.log_path, self._status = name, alive, log_path, status

    @classmethod
    def process(cls, name, proc, log_path=None):
        """A subprocess.Popen."""
        return cls(name, lambda: proc.poll() is None, log_path, lambda: proc.returncode)

    def status(self):
        return self._status() if self._status else None


def tail(path, n=30):
    """The last n lines of a text file ("" when it cannot be read)."""
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-n:])
    except OSError:
        return ""


def check_alive(watch, what):
    """RuntimeError naming the first of watch (one Watched-like thing, or a list or tuple
    of them) that has ended, its exit status and the last lines of its log, while waiting
    for what."""
    for w in (watch if isinstance(watch, (list, tuple)) else [watch] if watch is not None else []):
        if not w.alive():
            status = w.status()
            said = f" (exit status {status})" if status is not None else ""
            log = f"; last lines of {w.log_path}:\n{tail(w.log_path)}" if w.log_path else ""
            raise RuntimeError(f"{w.name} ended{said} while waiting for {what}{log}")


def wait_for(predicate, timeout, what, watch=None, poll=0.05):
    """Wait until predicate() is true; RuntimeError naming `what` on timeout or when one of
    watch (a RoslaunchSession, Roscore or Watched, or a sequence of them) ended."""
    end = time.monotonic() + timeout
    while not predicate():
        check_alive(watch, what)
        if time.monotonic() > end:
            raise RuntimeError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(poll)
