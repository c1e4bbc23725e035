"""The battery model (summit_xl_sim.battery): drain at rest and moving against hand-computed
energies, the charger only when stopped within the dock radius, the full-charge time,
voltage and current signs, the set limits; in the Simulation: drain, docking, empty."""
import math
import os

import pytest
import yaml

from summit_xl_sim import battery as bt
from summit_xl_sim.battery import Battery, BatteryParams, near_dock, parse_dock
from summit_xl_sim.sim import Simulation
from summit_xl_sim.world import World

PARAMS = BatteryParams(capacity_wh=100.0, idle_w=30.0, per_mps_w=40.0, per_radps_w=10.0, charge_w=200.0)
HERE = os.path.dirname(os.path.abspath(__file__))
RACE = os.path.join(HERE, "..", "config", "race_track_battery.yaml")
HALL = (2.0, 7.0)  # the built-in world's spawn, in the open hall [m]


@pytest.fixture(scope="module")
def world():
    return World.from_yaml(os.path.join(HERE, "..", "worlds", "course_building.yaml"))


def run(b, seconds, speed, turn, at_dock, dt=0.005):
    for _ in range(int(round(seconds / dt))):
        b.step(dt, speed, turn, at_dock)


def test_drain_at_rest_is_idle_power_times_time():
    b = Battery(PARAMS, 1.0)
    run(b, 60.0, 0.0, 0.0, False)
    # 30 W for 60 s = 1800 J of 100 Wh = 360000 J -> 0.5 %.
    assert b.percentage == pytest.approx(1.0 - 1800.0 / 360000.0, abs=1e-9)
    assert b.status == bt.POWER_SUPPLY_STATUS_DISCHARGING


def test_drain_moving_adds_per_mps_and_per_radps():
    b = Battery(PARAMS, 0.8)
    run(b, 100.0, -0.5, -0.4, False)  # signs do not matter: |v|, |w|
    # (30 + 40 * 0.5 + 10 * 0.4) W = 54 W for 100 s = 5400 J -> 1.5 %.
    assert b.percentage == pytest.approx(0.8 - 0.015, abs=1e-9)
    assert b.current == pytest.approx(-54.0 / b.open_circuit_voltage)
    assert b.current < 0 and b.voltage < b.open_circuit_voltage


def test_charges_only_stopped_within_the_dock():
    b = Battery(PARAMS, 0.5)
    run(b, 10.0, 0.3, 0.0, True)  # at the dock but moving: contacts touch, charger off
    assert b.percentage < 0.5 and not b.charging
    assert b.status == bt.POWER_SUPPLY_STATUS_NOT_CHARGING
    p = b.percentage
    run(b, 10.0, 0.0, 0.0, False)  # stopped away from the dock
    assert b.percentage < p and b.status == bt.POWER_SUPPLY_STATUS_DISCHARGING
    p = b.percentage
    run(b, 10.0, 0.005, 0.005, True)  # below the stop thresholds, at the dock: 200 W in
    assert b.percentage == pytest.approx(p + 2000.0 / 360000.0, abs=1e-9)
    assert b.charging and b.status == bt.POWER_SUPPLY_STATUS_CHARGING
    assert b.current > 0 and b.voltage > b.open_circuit_voltage


def test_full_charge_takes_capacity_over_charge_power_then_full():
    b = Battery(PARAMS, 0.0)
    dt = 0.005
    steps = 0
    while b.percentage < 1.0:
        b.step(dt, 0.0, 0.0, True)
        steps += 1
    assert steps * dt == pytest.approx(100.0 * 3600.0 / 200.0, abs=dt)  # 1800 s
    b.step(dt, 0.0, 0.0, True)
    assert b.percentage == 1.0 and b.status == bt.POWER_SUPPLY_STATUS_FULL and not b.charging
    assert b.current == 0.0


def test_voltage_follows_the_lifepo4_curve():
    assert bt.cell_ocv(0.5) == pytest.approx(3.30)
    assert bt.cell_ocv(0.15) == pytest.approx((3.20 + 3.25) / 2)
    assert bt.cell_ocv(1.0) == pytest.approx(3.40) and bt.cell_ocv(0.0) == pytest.approx(2.80)
    b = Battery(PARAMS, 0.5)
    assert b.open_circuit_voltage == pytest.approx(8 * 3.30)
    assert b.capacity_ah == pytest.approx(100.0 / 25.6)


@pytest.mark.parametrize("value", [-0.01, 1.01, float("nan"), float("inf"), "half", None])
def test_set_percentage_refuses_out_of_range(value):
    b = Battery(PARAMS, 0.7)
    with pytest.raises(ValueError, match="percentage must be"):
        b.set_percentage(value)
    assert b.percentage == pytest.approx(0.7)


def test_set_percentage_limits_are_accepted():
    b = Battery(PARAMS, 0.7)
    b.set_percentage(0)
    assert b.percentage == 0.0 and b.empty
    b.set_percentage(1)
    assert b.percentage == 1.0


@pytest.mark.parametrize("field, value, name", [
    ("capacity_wh", 0.0, "battery_capacity_wh"), ("capacity_wh", -5.0, "battery_capacity_wh"),
    ("idle_w", float("nan"), "battery_idle_w"), ("per_mps_w", -1.0, "battery_per_mps_w"),
    ("per_radps_w", "x", "battery_per_radps_w"), ("charge_w", 0.0, "battery_charge_w"),
])
def test_bad_params_name_the_parameter(field, value, name):
    with pytest.raises(ValueError, match=name):
        BatteryParams(**{field: value})


def test_parse_dock_forms_and_errors():
    assert parse_dock({"x": 1.0, "y": -2.0, "yaw_deg": 90.0}) == pytest.approx((1.0, -2.0, math.pi / 2))
    assert parse_dock([1, 2, 180]) == pytest.approx((1.0, 2.0, math.pi))
    assert parse_dock("") is None and parse_dock({}) is None and parse_dock(None) is None
    for bad, msg in (({"x": 1}, "missing y"), ([1, "a", 0], "numbers"), (7, "must be"),
                     ([1, 2, 3, 4], "must be"), ({"x": 1, "y": float("inf")}, "finite")):
        with pytest.raises(ValueError, match="~dock.*" + msg):
            parse_dock(bad, "~dock")


def test_near_dock_radius():
    docks = [(0.0, 0.0, 0.0), (5.0, 5.0, 0.0)]
    assert near_dock(0.2, 0.2, docks, 0.3) and near_dock(5.0, 4.75, docks, 0.3)
    assert not near_dock(0.25, 0.25, docks, 0.3)


def test_race_track_values_charge_in_two_minutes_and_a_lap_uses_10_to_15_percent():
    with open(RACE) as f:
        cfg = yaml.safe_load(f)
    p = BatteryParams(capacity_wh=cfg["battery_capacity_wh"], idle_w=cfg["battery_idle_w"],
                      per_mps_w=cfg["battery_per_mps_w"], per_radps_w=cfg["battery_per_radps_w"],
                      charge_w=cfg["battery_charge_w"])
    assert p.capacity_wh * 3600.0 / p.charge_w <= 120.0  # full charge [s]
    def lap_share(speed):  # a 70 m lap turning through ~900 deg in all (its corners)
        lap_s = 70.0 / speed
        return lap_s * (p.idle_w + p.per_mps_w * speed + p.per_radps_w * math.radians(900.0) / lap_s) \
            / (p.capacity_wh * 3600.0)

    # The race track's cruise: max_vel_x 0.5 m/s, slowing at each waypoint (0.45 m/s mean).
    assert 0.10 <= lap_share(0.45) <= 0.15


def test_simulation_drains_while_driving_and_charges_at_the_dock(world):
    sim = Simulation(world, docks=[(2.0, 7.0, 0.0)], dock_radius=0.3)
    s = sim.add_robot("r", *HALL, 0.0, battery=Battery(PARAMS, 0.5))
    for _ in range(200):  # 1 s at the dock, stopped: +200 J
        sim.step(0.005)
    assert s.battery.percentage == pytest.approx(0.5 + 200.0 / 360000.0, abs=1e-9)
    assert s.battery.status == bt.POWER_SUPPLY_STATUS_CHARGING
    p = s.battery.percentage
    for _ in range(400):  # drive away at 0.5 m/s for 2 s
        sim.command("r", 0.5, 0.0, 0.0)
        sim.step(0.005)
    assert s.pose[0] > 2.5 and s.battery.percentage < p
    assert s.battery.status == bt.POWER_SUPPLY_STATUS_DISCHARGING


def test_empty_pack_cuts_the_motors(world):
    sim = Simulation(world)
    s = sim.add_robot("r", *HALL, 0.0, battery=Battery(PARAMS, 0.0))
    for _ in range(200):
        sim.command("r", 0.5, 0.0, 0.0)
        sim.step(0.005)
    assert s.pose[0] == 2.0 and s.vel == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("pct, status, level, message", [
    (0.57, bt.POWER_SUPPLY_STATUS_DISCHARGING, bt.DIAG_OK, "57 % discharging"),
    (0.20, bt.POWER_SUPPLY_STATUS_DISCHARGING, bt.DIAG_OK, "20 % discharging"),
    (0.15, bt.POWER_SUPPLY_STATUS_DISCHARGING, bt.DIAG_WARN, "15 % discharging (low: below 20 %)"),
    (0.12, bt.POWER_SUPPLY_STATUS_CHARGING, bt.DIAG_WARN, "12 % charging at the dock (low: below 20 %)"),
    (0.05, bt.POWER_SUPPLY_STATUS_DISCHARGING, bt.DIAG_WARN, "5 % discharging (low: below 20 %)"),
    (0.03, bt.POWER_SUPPLY_STATUS_DISCHARGING, bt.DIAG_ERROR, "3 % discharging (critical: below 5 %)"),
    (0.0, bt.POWER_SUPPLY_STATUS_DISCHARGING, bt.DIAG_ERROR, "0 % discharging (empty: the motors are cut)"),
    (1.0, bt.POWER_SUPPLY_STATUS_FULL, bt.DIAG_OK, "100 % full at the dock"),
    (0.8, bt.POWER_SUPPLY_STATUS_NOT_CHARGING, bt.DIAG_OK, "80 % at the dock, moving: not charging"),
])
def test_diagnostic_level(pct, status, level, message):
    assert bt.diagnostic_level(pct, status, warn=0.2, error=0.05) == (level, message)


def test_diagnostic_thresholds_are_checked():
    assert bt.check_thresholds(0.2, 0.05) == (0.2, 0.05)
    with pytest.raises(ValueError, match="battery_error .* must not exceed battery_warn"):
        bt.check_thresholds(0.1, 0.2)
    with pytest.raises(ValueError, match="battery_warn must be in 0..1"):
        bt.check_thresholds(20, 0.05)
