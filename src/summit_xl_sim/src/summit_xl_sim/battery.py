"""Battery of the simulated Summit XL: energy drain while driving, a charger at the dock.

Model (an energy balance, no electrochemistry):
- Drain: the power the robot draws is P = idle_w + per_mps_w * |v| + per_radps_w * |w|
  [W] (computers and sensors at rest, plus the motors, proportional to the linear speed
  |v| [m/s] and the turn rate |w| [rad/s]); the stored energy falls by P * dt.
- Charger: while the robot stands still (|v| < STOP_SPEED, |w| < STOP_TURN_RATE) within
  the dock radius of a dock, the charger feeds the robot's load and puts charge_w [W]
  into the pack (constant power to full; the constant-voltage taper of a real charger is
  left out, so a full charge takes exactly capacity_wh / charge_w hours).
- Terminal voltage: the pack's open-circuit voltage at its state of charge plus the
  current times the internal resistance (current < 0 discharging, as
  sensor_msgs/BatteryState says, so the voltage sags under load and rises on charge).
  The open-circuit voltage is interpolated in a typical LiFePO4 cell curve (the flat
  ~3.3 V plateau between 10 % and 90 %, knees at both ends; rounded values of the curves
  cell makers publish, an assumption rather than one cell's datasheet) times 8 cells.
- Empty: at 0 % the pack's protection cuts the motors (``empty``); the simulator then
  drops the robot's command, as a real Summit XL stops when its BMS disconnects.

Defaults (``BatteryParams``): the Summit XL's pack as Robotnik describes the robot, a
24 V-class LiFePO4 battery of 15 Ah (modelled as 8 cells in series, 25.6 V nominal,
384 Wh); the loads are our assumptions (30 W at rest for the PC, laser and drivers;
40 W more per m/s; 10 W per rad/s), giving ~13 h at rest and ~5.5 h at 1 m/s; the
charger's 200 W (29.2 V, ~7 A) charges it in ~2 h. The race track's demo values
(config/race_track_battery.yaml) shrink the pack and grow the charger so a run shows
several charging stops in minutes. Pure: no rospy; scalar maths per step.
"""
import bisect
import math
from dataclasses import dataclass

# sensor_msgs/BatteryState's power_supply_status constants (plain ints: no ROS here).
POWER_SUPPLY_STATUS_CHARGING = 1
POWER_SUPPLY_STATUS_DISCHARGING = 2
POWER_SUPPLY_STATUS_NOT_CHARGING = 3
POWER_SUPPLY_STATUS_FULL = 4
STATUS_NAMES = {POWER_SUPPLY_STATUS_CHARGING: "charging", POWER_SUPPLY_STATUS_DISCHARGING: "discharging",
                POWER_SUPPLY_STATUS_NOT_CHARGING: "not charging", POWER_SUPPLY_STATUS_FULL: "full"}

STOP_SPEED = 0.01       # [m/s] below this linear speed the robot counts as stopped (charger on)
STOP_TURN_RATE = 0.01   # [rad/s] the same for the turn rate
CELLS_IN_SERIES = 8     # LiFePO4 cells of the 24 V-class pack (8 x 3.2 V = 25.6 V nominal)
NOMINAL_CELL_V = 3.2    # [V] LiFePO4 nominal cell voltage, for the pack's Ah capacity
# Open-circuit voltage of one LiFePO4 cell [V] against state of charge [0..1].
OCV_SOC = (0.0, 0.05, 0.10, 0.20, 0.30, 0.40, 0.50, 0.60, 0.70, 0.80, 0.90, 0.95, 1.0)
OCV_CELL_V = (2.80, 3.10, 3.20, 3.25, 3.27, 3.29, 3.30, 3.31, 3.32, 3.33, 3.34, 3.36, 3.40)
WH = 3600.0             # [J] per watt-hour


@dataclass
class BatteryParams:
    """Battery and charger parameters (names as the simulator's ~battery_* parameters)."""

    capacity_wh: float = 384.0      # usable energy when full [Wh]
    idle_w: float = 30.0            # load at rest [W]
    per_mps_w: float = 40.0         # extra load per m/s of linear speed [W / (m/s)]
    per_radps_w: float = 10.0       # extra load per rad/s of turn rate [W / (rad/s)]
    charge_w: float = 200.0         # power the dock's charger puts into the pack [W]
    resistance_ohm: float = 0.04    # pack internal resistance [ohm] (8 cells + wiring)

    def __post_init__(self):
        checks = (("battery_capacity_wh", self.capacity_wh, False), ("battery_idle_w", self.idle_w, True),
                  ("battery_per_mps_w", self.per_mps_w, True), ("battery_per_radps_w", self.per_radps_w, True),
                  ("battery_charge_w", self.charge_w, False), ("battery_resistance_ohm", self.resistance_ohm, True))
        for name, value, zero_ok in checks:
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value) \
                    or value < 0.0 or (value == 0.0 and not zero_ok):
                raise ValueError(f"{name} must be a finite number {'>=' if zero_ok else '>'} 0, got {value!r}")


def check_percentage(value, name="percentage"):
    """``value`` as a float in 0..1; ValueError naming ``name`` otherwise."""
    try:
        p = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number in 0..1, got {value!r}") from None
    if not math.isfinite(p) or not 0.0 <= p <= 1.0:
        raise ValueError(f"{name} must be in 0..1 (a fraction, not a percent), got {value!r}")
    return p


def cell_ocv(soc):
    """Open-circuit voltage [V] of one LiFePO4 cell at state of charge soc [0..1]."""
    soc = min(1.0, max(0.0, soc))
    i = min(bisect.bisect_right(OCV_SOC, soc), len(OCV_SOC) - 1)
    s0, s1, v0, v1 = OCV_SOC[i - 1], OCV_SOC[i], OCV_CELL_V[i - 1], OCV_CELL_V[i]
    return v0 + (v1 - v0) * (soc - s0) / (s1 - s0)


class Battery:
    """One robot's pack: state of charge, stepped with the robot's true velocity."""

    def __init__(self, params=None, percentage=1.0):
        self.params = params or BatteryParams()
        self.energy_j = 0.0
        self.set_percentage(percentage)
        self.charging = False       # the charger feeds the pack (stopped at a dock, not full)
        self.at_dock = False        # within the dock radius (the contacts touch)
        self.power_w = self.params.idle_w  # pack power [W]: > 0 into the pack, < 0 out of it

    @property
    def capacity_j(self):
        """Usable energy when full [J]."""
        return self.params.capacity_wh * WH

    @property
    def percentage(self):
        """State of charge [0..1]."""
        return self.energy_j / self.capacity_j

    @property
    def empty(self):
        """True at 0 %: the pack's protection has cut the motors."""
        return self.energy_j <= 0.0

    def set_percentage(self, value):
        """Set the state of charge [0..1]; ValueError (naming 'percentage') when it is not
        a finite number in 0..1."""
        self.energy_j = check_percentage(value) * self.capacity_j

    def load_w(self, speed, turn_rate):
        """Power the robot draws [W] at linear speed [m/s] and turn rate [rad/s]."""
        p = self.params
        return p.idle_w + p.per_mps_w * abs(speed) + p.per_radps_w * abs(turn_rate)

    def step(self, dt, speed, turn_rate, at_dock):
        """Advance dt [s] at linear speed [m/s] and turn rate [rad/s]; at_dock: the robot
        is within the dock radius of a dock (the charger works only when it also stands
        still)."""
        self.at_dock = at_dock
        stopped = abs(speed) < STOP_SPEED and abs(turn_rate) < STOP_TURN_RATE
        full = self.energy_j >= self.capacity_j
        self.charging = at_dock and stopped and not full
        if at_dock and stopped:
            # The dock's supply feeds the load; the pack takes charge_w until full.
            self.power_w = self.params.charge_w if not full else 0.0
        else:
            self.power_w = -self.load_w(speed, turn_rate)
        self.energy_j = min(self.capacity_j, max(0.0, self.energy_j + self.power_w * dt))

    @property
    def open_circuit_voltage(self):
        """Pack open-circuit voltage [V] at the present state of charge."""
        return CELLS_IN_SERIES * cell_ocv(self.percentage)

    @property
    def current(self):
        """Pack current [A]: negative discharging, positive charging (BatteryState)."""
        return self.power_w / self.open_circuit_voltage

    @property
    def voltage(self):
        """Pack terminal voltage [V]: sags under load, rises on charge."""
        return self.open_circuit_voltage + self.current * self.params.resistance_ohm

    @property
    def capacity_ah(self):
        """Capacity [Ah] at the nominal pack voltage, for BatteryState.capacity."""
        return self.params.capacity_wh / (CELLS_IN_SERIES * NOMINAL_CELL_V)

    @property
    def status(self):
        """sensor_msgs/BatteryState power_supply_status: CHARGING at the dock while the
        charger works, FULL at the dock when full, NOT_CHARGING at the dock while
        moving (contacts touch, charger off), DISCHARGING away from it."""
        if self.charging:
            return POWER_SUPPLY_STATUS_CHARGING
        if self.at_dock:
            stopped = self.power_w >= 0.0
            return POWER_SUPPLY_STATUS_FULL if stopped else POWER_SUPPLY_STATUS_NOT_CHARGING
        return POWER_SUPPLY_STATUS_DISCHARGING


def near_dock(x, y, docks, radius):
    """True when (x, y) [m] is within radius [m] of any dock [(x, y, yaw)] [m, m, rad]."""
    r2 = radius * radius
    for dx, dy, _ in docks:
        if (x - dx) * (x - dx) + (y - dy) * (y - dy) <= r2:
            return True
    return False


def parse_dock(value, name="dock"):
    """A dock pose (x [m], y [m], yaw [rad]) from {x, y, yaw_deg} or [x, y, yaw_deg]; None
    for an empty value (no dock). ValueError naming ``name`` when malformed."""
    if value is None or value == "" or value == [] or value == {}:
        return None
    if isinstance(value, dict):
        missing = [k for k in ("x", "y") if k not in value]
        if missing:
            raise ValueError(f"{name} needs x and y (and yaw_deg), missing {', '.join(missing)}: {value!r}")
        vals = [value["x"], value["y"], value.get("yaw_deg", 0.0)]
    elif isinstance(value, (list, tuple)) and len(value) in (2, 3):
        vals = list(value) + ([0.0] if len(value) == 2 else [])
    else:
        raise ValueError(f"{name} must be {{x, y, yaw_deg}} or [x, y, yaw_deg], got {value!r}")
    try:
        x, y, yaw_deg = (float(v) for v in vals)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: x, y, yaw_deg must be numbers, got {value!r}") from None
    if not all(math.isfinite(v) for v in (x, y, yaw_deg)):
        raise ValueError(f"{name}: x, y, yaw_deg must be finite, got {value!r}")
    return (x, y, math.radians(yaw_deg))


# diagnostic_msgs/DiagnosticStatus levels (plain ints: no ROS here).
DIAG_OK, DIAG_WARN, DIAG_ERROR = 0, 1, 2


def check_thresholds(warn, error):
    """(warn, error) [0..1] as floats; ValueError naming the parameter unless
    0 <= error <= warn <= 1."""
    warn = check_percentage(warn, "battery_warn")
    error = check_percentage(error, "battery_error")
    if error > warn:
        raise ValueError(f"battery_error ({error}) must not exceed battery_warn ({warn})")
    return warn, error


def diagnostic_level(percentage, status, warn=0.2, error=0.05):
    """The battery's diagnostic (level, message): OK at or above ``warn`` [0..1], WARN
    below it, ERROR below ``error``; the message gives the level in percent and what the
    charger does, e.g. "57 % discharging", "12 % charging at the dock (low: below 20 %)"."""
    pct = f"{percentage * 100.0:.0f} %"
    if status == POWER_SUPPLY_STATUS_CHARGING:
        what = f"{pct} charging at the dock"
    elif status == POWER_SUPPLY_STATUS_FULL:
        what = f"{pct} full at the dock"
    elif status == POWER_SUPPLY_STATUS_NOT_CHARGING:
        what = f"{pct} at the dock, moving: not charging"
    else:
        what = f"{pct} discharging"
    if percentage <= 0.0:
        return DIAG_ERROR, f"{what} (empty: the motors are cut)"
    if percentage < error:
        return DIAG_ERROR, f"{what} (critical: below {error * 100.0:.0f} %)"
    if percentage < warn:
        return DIAG_WARN, f"{what} (low: below {warn * 100.0:.0f} %)"
    return DIAG_OK, what
