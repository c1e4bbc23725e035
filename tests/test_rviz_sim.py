"""rviz really shows the simulated robot: sim.launch gui:=true under Xvfb, one screenshot.

Starts Xvfb on a free display, `roslaunch -p PORT summit_xl_sim sim.launch gui:=true` on a
free port (its own master), waits until the simulator has run 3 s (and rviz 2 s more), grabs the
screen with ImageMagick's `import -window root` and checks the pixels of rviz's render
panel (src/summit_xl_sim/rviz/sim.rviz: background 48;48;48, laser points flat green
0;255;0, top-down view following base_footprint at 40 px/m, so the robot sits in the
middle of the panel):
  * the panel is there and mostly background (not a black / blank / missing panel),
  * laser points: enough bright-green pixels, spread over the panel (walls all round),
  * the robot model: grey body (0.35 0.35 0.38 lit) and black wheels near the centre, in
    roughly the area 0.72 m x 0.40 m and four 0.22 m x 0.10 m wheels give at 40 px/m.
The same check must fail on a synthetic black panel, a blank panel, and on a real
screenshot of rviz with a fixed frame that does not exist (nothing can be transformed).

Run: source devel/setup.bash && /usr/bin/python3 -m pytest tests/test_rviz_sim.py
"""
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

import cv2  # noqa: E402

from rviz_util import (BACKGROUND, SCREEN, stop_process_tree, need, free_port,  # noqa: E402
                       render_area, ros_env, screenshot, spawn, wait_sim_time, xvfb)  # noqa: F401

pytestmark = pytest.mark.integration

SIM_SETTLE_S = 3.0        # [s] of simulated time before the screenshot (scans, tf, odometry) ...
RENDER_S = 2.0            # ... and then [s] of wall time for rviz to draw them
SIM_TIMEOUT_S = 90.0      # [s] wall: the simulator must have got that far by then


# ----------------------------------------------------------------------------- helpers
def run_sim_and_grab(spawn, display, tmp_path, name, extra_args=()):
    """sim.launch gui:=true, wait until the simulator has run SIM_SETTLE_S and rviz has
    had RENDER_S to draw, screenshot, stop the launch. -> RGB image."""
    need("roslaunch", "rviz", "rostopic")
    port = free_port()
    env = ros_env(display, port, tmp_path)
    log = open(tmp_path / ("%s_launch.log" % name), "wb")
    launch = spawn(["roslaunch", "-p", str(port), "summit_xl_sim", "sim.launch",
                    "gui:=true", "speed:=1"] + list(extra_args),
                   env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        t = wait_sim_time(env, SIM_SETTLE_S, SIM_TIMEOUT_S, [launch])
        assert t >= SIM_SETTLE_S, "the simulator reached only %.2f s of simulated time in %.0f s, see %s" % (
            t, SIM_TIMEOUT_S, log.name)
        deadline = time.time() + RENDER_S
        while time.time() < deadline:
            assert launch.poll() is None, "roslaunch exited early, see %s" % log.name
            time.sleep(0.25)
        img = screenshot(display, tmp_path / ("%s.png" % name))
    finally:
        stop_process_tree(launch)
        log.close()
    return img


# ------------------------------------------------------------------------ the pixel check
def analyse(img):
    """Pixel statistics of the render panel (all counts in pixels)."""
    box = render_area(img)
    if box is None:
        return {"panel": None}
    x0, y0, x1, y1 = box
    panel = img[y0:y1, x0:x1]
    r, g, b = panel[..., 0], panel[..., 1], panel[..., 2]
    bg = np.abs(panel - BACKGROUND).max(axis=2) <= 4
    laser = (g >= 200) & (r <= 80) & (b <= 80)
    # robot: the middle of the panel (view follows base_footprint), +-1.5 m
    h, w = bg.shape
    cy, cx, half = h // 2, w // 2, 60
    mid = panel[cy - half:cy + half, cx - half:cx + half]
    mr, mg, mb = mid[..., 0], mid[..., 1], mid[..., 2]
    body = (mr >= 78) & (mr <= 105) & (np.abs(mr - mg) <= 3) & (mb - mr >= 4) & (mb - mr <= 14)
    wheels = (mid.max(axis=2) <= 32) & (mid.max(axis=2) - mid.min(axis=2) <= 4)
    ys, xs = np.nonzero(laser)
    return {
        "panel": box,
        "panel_px": int(bg.size),
        "background_frac": float(bg.mean()),
        "laser_px": int(laser.sum()),
        # how many of the panel's 4x4 sectors hold laser points (walls all round)
        "laser_sectors": int(len(set(zip((ys * 4 // h).tolist(), (xs * 4 // w).tolist())))),
        "body_px": int(body.sum()),
        "wheel_px": int(wheels.sum()),
    }


def check(stats):
    """List of reasons the render is not a good view; empty when it is."""
    if stats["panel"] is None:
        return ["no rviz render panel (no large area of background colour 48;48;48)"]
    bad = []
    x0, y0, x1, y1 = stats["panel"]
    if (x1 - x0) * (y1 - y0) < 0.3 * SCREEN[0] * SCREEN[1]:
        bad.append("render panel too small: %s" % (stats["panel"],))
    if not 0.6 <= stats["background_frac"] <= 0.995:
        bad.append("background fraction %.3f not in [0.6, 0.995]" % stats["background_frac"])
    if not 0.001 * stats["panel_px"] <= stats["laser_px"] <= 0.1 * stats["panel_px"]:
        bad.append("laser pixels %d not 0.1%%..10%% of the panel" % stats["laser_px"])
    if stats["laser_sectors"] < 4:
        bad.append("laser points in only %d of 16 sectors" % stats["laser_sectors"])
    # body 0.72 x 0.40 m = 29 x 16 px = 460 px at 40 px/m (less where tf axes cross it)
    if not 150 <= stats["body_px"] <= 1500:
        bad.append("robot body pixels %d not in [150, 1500]" % stats["body_px"])
    # four wheels 0.22 x 0.10 m = 35 px each, partly under the body
    if not 20 <= stats["wheel_px"] <= 800:
        bad.append("robot wheel pixels %d not in [20, 800]" % stats["wheel_px"])
    return bad


# --------------------------------------------------------------------------------- tests
def test_check_rejects_blank_and_black_panels(tmp_path):
    """The pixel check itself: a synthetic good frame passes, blank/black ones fail."""
    img = np.full((SCREEN[1], SCREEN[0], 3), 239, np.int16)      # Qt window grey
    img[62:702, 364:1264] = BACKGROUND                              # render panel
    assert check(analyse(img)), "an empty panel must fail"
    black = img.copy()
    black[62:702, 364:1264] = 0
    assert check(analyse(black)), "a black panel must fail"
    good = img.copy()
    cy, cx = (62 + 702) // 2, (364 + 1264) // 2
    good[cy - 8:cy + 8, cx - 14:cx + 15] = (89, 89, 97)            # body
    for dx in (-9, 9):
        for dy in (-11, 11):
            good[cy + dy - 2:cy + dy + 2, cx + dx - 4:cx + dx + 5] = (25, 25, 25)
    good[100:103, 400:1200] = (0, 255, 0)                           # walls
    good[600:603, 400:1200] = (0, 255, 0)
    good[100:600, 400:403] = (0, 255, 0)
    good[100:600, 1200:1203] = (0, 255, 0)
    assert check(analyse(good)) == [], check(analyse(good))


def test_rviz_shows_robot_tf_and_scan(spawn, xvfb, tmp_path):
    img = run_sim_and_grab(spawn, xvfb, tmp_path, "sim_rviz")
    stats = analyse(img)
    problems = check(stats)
    assert not problems, "rviz view not right (%s): %s; screenshot %s" % (
        stats, problems, tmp_path / "sim_rviz.png")


def test_check_fails_with_wrong_fixed_frame(spawn, xvfb, tmp_path):
    """Real negative: rviz with Fixed Frame `map` (nobody publishes it): no robot, no scan."""
    import rospkg
    cfg = Path(rospkg.RosPack().get_path("summit_xl_sim")) / "rviz" / "sim.rviz"
    text = cfg.read_text()
    assert "    Fixed Frame: odom\n" in text
    bad_cfg = tmp_path / "wrong_frame.rviz"
    bad_cfg.write_text(text.replace("    Fixed Frame: odom\n", "    Fixed Frame: map\n"))
    img = run_sim_and_grab(spawn, xvfb, tmp_path, "wrong_frame",
                           ["rviz_config:=%s" % bad_cfg])
    stats = analyse(img)
    assert check(stats), "check passed a view that cannot show anything: %s" % (stats,)
    assert stats["panel"] is None or stats["laser_px"] < 0.001 * stats["panel_px"], stats
