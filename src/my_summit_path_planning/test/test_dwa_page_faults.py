"""DWA's control cycle takes no fresh pages from the kernel once warm, under move_base's
malloc settings (summit_nav_common.malloc.limit_arenas).

bench_stack_cpu.py at 2168d06: move_base spent 0.64 CPU s per simulated s against 0.42 at
b2f449a on the same machine, a third of it system time: 129,000 minor page faults a
second. limit_arenas (e06d045) hands every block of 256 KiB or more to mmap and trims the
heap's top above 1 MiB, and DWA's (800 samples x 76 steps) float64 arrays, 0.5 MB each,
were mapped and zeroed anew every cycle: 4,200 faults a cycle, 15 ms of CPU against 8.5.
Now DWA evaluates its samples in blocks below the threshold and the heap keeps 4 MiB at
its top. Run in a fresh interpreter: mallopt's settings hold for the whole process.
"""
import json
import os
import statistics
import subprocess
import sys

CHILD = r"""
import json, resource
import numpy as np
from summit_nav_common.malloc import limit_arenas
assert limit_arenas() == ""
from my_summit_path_planning import cost_values as cv
from my_summit_path_planning.costmap import Costmap2D, Footprint, LayeredCostmap
from my_summit_path_planning.dwa import DWAConfig, DWAPlanner

footprint = Footprint.from_params([[0.36, 0.31], [-0.36, 0.31], [-0.36, -0.31], [0.36, -0.31]])
lc = LayeredCostmap.from_plugins([{"name": "inflation", "type": "costmap_2d::InflationLayer"}],
                                 {"inflation": {"inflation_radius": 0.8, "cost_scaling_factor": 5.0}},
                                 Costmap2D(140, 140, 0.05, -3.5, -3.5), footprint)
m = lc.master
m.data[100:103, :] = cv.LETHAL_OBSTACLE    # walls 1.5 m either side of y = 0
m.data[37:40, :] = cv.LETHAL_OBSTACLE
lc.layers[0].update_costs(m, (0, 0, 140, 140))
cfg = DWAConfig(max_vel_x=1.0, min_vel_x=0.0, max_vel_y=0.0, min_vel_y=0.0, max_vel_trans=1.0,
                min_vel_trans=0.1, max_vel_theta=3.0, min_vel_theta=0.3, acc_lim_x=2.5, acc_lim_theta=5.0,
                vx_samples=20, vy_samples=1, vth_samples=40, sim_time=1.7, sim_granularity=0.025)
planner = DWAPlanner(cfg, footprint)
planner.set_plan(np.column_stack([np.linspace(0.0, 3.0, 61), 0.2 * np.sin(np.linspace(0.0, 3.0, 61))]), 0.0)
rng = np.random.default_rng(0)
faults = []
for i in range(40):
    vel = (rng.uniform(0.0, 1.0), 0.0, rng.uniform(-1.0, 1.0))
    f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    r = planner.compute_velocity((0.0, 0.0, 0.0), vel, m)
    faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
    planner.oscillation.reset()
    assert r.ok, r.reason
print(json.dumps({"faults": faults[10:], "samples": r.n_samples}))
"""


def test_a_warm_dwa_cycle_maps_no_fresh_pages():
    out = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=300,
                         env=dict(os.environ))
    assert out.returncode == 0, out.stderr[-3000:]
    res = json.loads(out.stdout.strip().splitlines()[-1])
    assert res["samples"] >= 800
    # Before: ~4,200 a cycle (arrays mmapped), ~700 with blocks but a 1 MiB trim threshold.
    assert statistics.median(res["faults"]) <= 20, res["faults"]
