"""Shared helpers of the rviz screenshot tests (test_rviz_sim.py, test_rviz_steps.py).

A private Xvfb (display number picked by Xvfb itself), a free master port per launch,
processes started in their own sessions and killed by PID only (never by name), an
ImageMagick screenshot of the root window, and the location of rviz's render panel in it.
Import from a test module (tests/ is on tests/pytest.ini's pythonpath) and re-export the
fixtures `spawn` and `xvfb`.
"""
import os
import select
import shutil
import subprocess
import time

import numpy as np
import pytest

from summit_nav_common.testing.roslaunch_session import free_port, stop_process_tree  # noqa: F401  (re-exported)

SCREEN = (1280, 800)
BACKGROUND = np.array([48, 48, 48])   # rviz's default background colour (RGB)


def need(*exes):
    """Fail the test, naming them, when executables `make setup` installs are missing."""
    missing = [e for e in exes if shutil.which(e, path="/usr/bin:/bin") is None
               and shutil.which(e) is None]
    if missing:
        pytest.fail("missing executables (run `make setup`): %s" % ", ".join(missing))


@pytest.fixture
def spawn(request):
    """spawn(cmd, **popen_kw) -> Popen in its own process group, killed at teardown."""
    procs = []

    def _spawn(cmd, **kw):
        p = subprocess.Popen(cmd, start_new_session=True, stdin=subprocess.DEVNULL, **kw)
        procs.append(p)
        return p

    def _fin():
        for p in reversed(procs):
            stop_process_tree(p)
    request.addfinalizer(_fin)
    return _spawn


def start_xvfb(size=SCREEN):
    """-> (Popen, ':N'): a private X server, N picked by Xvfb itself (-displayfd)."""
    rfd, wfd = os.pipe()
    proc = subprocess.Popen(
        ["Xvfb", "-displayfd", str(wfd), "-screen", "0", "%dx%dx24" % size,
         "-nolisten", "tcp"],
        pass_fds=(wfd,), start_new_session=True, stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(wfd)
    # read up to the newline before closing: Xvfb writes the number and the "\n" in two
    # writes, and dies ("Cannot write display number") if the pipe is closed in between
    data, deadline = b"", time.time() + 15.0
    while not data.endswith(b"\n"):
        ready, _, _ = select.select([rfd], [], [], max(0.0, deadline - time.time()))
        chunk = os.read(rfd, 32) if ready else b""
        if not chunk:
            break
        data += chunk
    os.close(rfd)
    number = data.decode().strip()
    if not number.isdigit():
        stop_process_tree(proc, grace=3.0)
        raise RuntimeError("Xvfb did not report a display number")
    return proc, ":" + number


@pytest.fixture(scope="module")
def xvfb(request):
    """A private X server for the module; yields its DISPLAY string (':N')."""
    need("Xvfb", "import")
    try:
        proc, display = start_xvfb()
    except RuntimeError as e:
        pytest.fail(str(e))
    request.addfinalizer(lambda: stop_process_tree(proc, grace=3.0))
    return display


def ros_env(display, port, log_dir):
    """os.environ for a ROS process on its own master (port) and X display."""
    env = dict(os.environ)
    env["PATH"] = "/usr/bin:/bin:/usr/sbin:/sbin:" + env.get("PATH", "")
    env["ROS_MASTER_URI"] = "http://localhost:%d" % port
    env["ROS_HOSTNAME"] = "localhost"
    env["ROS_LOG_DIR"] = str(log_dir)
    env["DISPLAY"] = display
    env["XDG_RUNTIME_DIR"] = str(log_dir)
    return env


def wait_alive(procs, seconds, what="process", logs=None):
    """Sleep `seconds` of wall time, failing as soon as one of procs has exited."""
    deadline = time.time() + seconds
    while time.time() < deadline:
        for i, p in enumerate(procs):
            assert p.poll() is None, "%s exited early (rc %s)%s" % (
                what, p.returncode, ", see %s" % logs[i] if logs else "")
        time.sleep(0.25)


def screenshot(display, path):
    """Grab the whole X screen into path; -> the picture as an RGB int16 array."""
    import cv2
    subprocess.run(["import", "-display", display, "-window", "root", str(path)],
                   check=True, timeout=20, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert img is not None, "screenshot %s unreadable" % path
    return img[:, :, ::-1].astype(np.int16)  # RGB


def background_mask(img, background=BACKGROUND, tol=4):
    return np.abs(img - background).max(axis=2) <= tol


def colour_mask(img, colours, tol=4):
    """Pixels within tol (per channel) of any of the RGB colours."""
    mask = np.zeros(img.shape[:2], bool)
    for c in colours:
        mask |= np.abs(img - np.asarray(c)).max(axis=2) <= tol
    return mask


def render_area(img, background=BACKGROUND, min_frac=0.3, min_size=200, mask=None):
    """Bounding box (x0, y0, x1, y1) of rviz's render panel: the biggest block of rows
    and columns where at least min_frac of the pixels have the background colour (or are
    set in `mask`, a boolean image of the colours the panel is made of). None when there
    is none."""
    bg = background_mask(img, background) if mask is None else mask

    def longest_run(mask, max_gap=8):
        # grid lines cross the panel every metre: bridge gaps up to max_gap pixels
        mask = mask.copy()
        idx = np.nonzero(mask)[0]
        for a, b in zip(idx[:-1], idx[1:]):
            if 1 < b - a <= max_gap:
                mask[a:b] = True
        best, start = (0, 0), None
        for i, v in enumerate(list(mask) + [False]):
            if v and start is None:
                start = i
            elif not v and start is not None:
                if i - start > best[1] - best[0]:
                    best = (start, i)
                start = None
        return best

    x0, x1 = longest_run(bg.mean(axis=0) > min_frac)
    y0, y1 = longest_run(bg.mean(axis=1) > min_frac)
    if x1 - x0 < min_size or y1 - y0 < min_size:
        return None
    return x0, y0, x1, y1


def wait_param(port, name, timeout=20.0, procs=()):
    """Wait until the master on localhost:port is up and has parameter `name` (e.g. the
    robot_description a launch file sets before it starts its nodes). -> True / False.
    Fails at once if one of procs has exited."""
    import xmlrpc.client
    master = xmlrpc.client.ServerProxy("http://localhost:%d" % port)
    deadline = time.time() + timeout
    while time.time() < deadline:
        for p in procs:
            assert p.poll() is None, "process %s exited early (rc %s)" % (p.args, p.returncode)
        try:
            code, _, has = master.hasParam("/rviz_test", name)
            if code == 1 and has:
                return True
        except (OSError, xmlrpc.client.Error):
            pass
        time.sleep(0.25)
    return False


def _poll_topic(env, topic, timeout, procs, accept):
    """Echo one message of `topic` (on env's master) at a time until accept(text) returns
    something other than None, and return that; None on timeout. Fails at once if one of
    procs has exited."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        for p in procs:
            assert p.poll() is None, "process %s exited early (rc %s)" % (p.args, p.returncode)
        try:
            out = subprocess.run(["rostopic", "echo", "-n", "1", topic], env=env, capture_output=True, text=True,
                                 timeout=max(1.0, min(10.0, deadline - time.time()))).stdout
        except subprocess.TimeoutExpired:
            continue
        got = accept(out)
        if got is not None:
            return got
        time.sleep(0.25)
    return None


def wait_message(env, topic, timeout=60.0, procs=(), nonempty=None):
    """Wait until a message comes on `topic` (on env's master) -- with `nonempty` (a field
    name), one in which that field is not an empty list: a loaded machine plans and draws
    late, so a fixed wall-clock wait can end before the message the picture needs.
    -> True when one came. Fails at once if one of procs has exited."""
    def accept(out):
        return True if out.strip() and (nonempty is None or ("%s: []" % nonempty) not in out) else None
    return _poll_topic(env, topic, timeout, procs, accept) is True


def wait_sim_time(env, seconds, timeout=60.0, procs=()):
    """Wait until /clock (on env's master) has reached `seconds` of simulated time: a
    loaded machine starts the simulator late and runs it slow, so a fixed wall-clock wait
    can end before it has published anything. -> the last sim time seen [s] (< seconds
    on timeout). Fails at once if one of procs has exited."""
    last = [-1.0]

    def accept(out):
        fields = dict(line.strip().split(":", 1) for line in out.splitlines() if ":" in line)
        try:
            last[0] = int(fields["secs"]) + int(fields["nsecs"]) * 1e-9
        except (KeyError, ValueError):
            return None
        return last[0] if last[0] >= seconds else None
    got = _poll_topic(env, "/clock", timeout, procs, accept)
    return last[0] if got is None else got
