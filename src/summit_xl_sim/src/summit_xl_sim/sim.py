"""The simulation core: robots moving in a World, with odometry, laser and collisions.

No ROS here: the node (nodes/summit_xl_sim) steps this core in simulated time and turns
its state into messages. Everything is deterministic for a given seed.

Collisions: every step the robot's footprint at its new pose is checked against the
walls (footprint sampled at half a cell), the boxes and the other robots (separating
axis test). A blocked move does not happen: the robot keeps its pose, its velocity drops
to zero, and one collision is counted per contact (a robot pushing against a wall for a
second counts once: a new collision is counted only after the robot has moved
CONTACT_RESET freely since the last blocked move).

Battery (summit_xl_sim.battery): each robot's pack is stepped with its true velocity;
the docks belong to the Simulation, and a robot standing still within ``dock_radius`` of
one charges. An empty pack cuts the motors: the robot's command is dropped.
"""
import math
from dataclasses import dataclass, field

import numpy as np

from summit_nav_common import geometry

from . import robot as rb
from .battery import Battery, near_dock
from .imu import ImuModel
from .laser_model import DEFAULT_LASER_MODEL, make_laser_model, report
from .world import World, WorldError, rects_overlap

DRIVES = ("diff", "omni")
# Extra seed words of a robot's own generators: [seed, index] draws the odometry's white
# noise and the laser's (as before these existed), [seed, index, k] each of these.
SKID_STREAM = 1
IMU_STREAM = 2
# Free travel [m] (footprint corners' path) after which a new block counts as a new collision.
CONTACT_RESET = 0.05


@dataclass
class LaserParams:
    """Hokuyo UTM-30LX-like laser (SPEC.md), mounted at ``mount`` in base_footprint.

    ``model`` names the range model (laser_model.LASER_MODELS): ``utm30lx`` (the
    datasheet's noise, mixed pixels, grazing dropouts) or ``ideal`` (Gaussian of
    ``noise_sigma``, which only that model uses).
    """

    n_beams: int = 1081
    angle_min: float = -2.356194490192345   # [rad] (-135 deg)
    angle_max: float = 2.356194490192345    # [rad] (+135 deg)
    range_min: float = 0.10                 # [m]
    range_max: float = 30.0                 # [m]
    noise_sigma: float = 0.01               # Gaussian range noise of the ideal model [m]
    rate: float = 40.0                      # [Hz] of simulated time
    mount: tuple = (0.25, 0.0, 0.0)         # (x [m], y [m], yaw [rad]) in base_footprint
    model: str = DEFAULT_LASER_MODEL        # range model: utm30lx | ideal

    @property
    def angle_increment(self):
        """Angle between consecutive beams [rad]."""
        return (self.angle_max - self.angle_min) / (self.n_beams - 1)

    def angles(self):
        """Beam angles (n_beams,) [rad] in the laser frame."""
        return np.linspace(self.angle_min, self.angle_max, self.n_beams)


@dataclass
class RobotState:
    """One simulated robot: true pose, odometry pose, velocities, command, counters."""

    name: str
    drive: str
    params: rb.RobotParams
    laser: LaserParams
    pose: tuple                       # ground truth (x, y, yaw) in the world [m, rad]
    odom_pose: tuple = (0.0, 0.0, 0.0)  # odometry's estimate, in the odom frame
    vel: tuple = (0.0, 0.0, 0.0)      # body velocity (vx, vy, wz) [m/s, rad/s]
    cmd: tuple = (0.0, 0.0, 0.0)      # last accepted command
    last_cmd_time: float = -math.inf  # sim time of the last command [s]
    collisions: int = 0
    last_hit: str = ""            # what the last collision was with (blocked_by's answer)
    in_contact: bool = False
    free_travel: float = 0.0          # [m] moved since the last blocked move
    odom_vel: tuple = (0.0, 0.0, 0.0)  # the odometry's twist (the wheels' view for skid)
    odom_model: str = "ideal"          # robot.ODOM_MODELS
    skid_scale: float = 0.0            # slowly varying part s(t) of the skid yaw scale [-]
    odom_budget: tuple = (0.0, 0.0, 0.0, 0.0)  # skid odometry's error budget (robot.skid_pose_budget_step)
    rng: np.random.Generator = field(default=None, repr=False)
    skid_rng: np.random.Generator = field(default=None, repr=False)   # draws of s(t)
    imu: object = field(default=None, repr=False)  # imu.ImuModel, or None: no IMU
    range_model: object = field(default=None, repr=False)  # laser_model.IdealLaser / Utm30lxLaser
    battery: Battery = field(default=None, repr=False)

    def rect(self):
        """Footprint as an oriented rectangle (cx, cy, yaw, half_length, half_width)."""
        x, y, yaw = self.pose
        return (x, y, yaw, self.params.length / 2.0, self.params.width / 2.0)


def default_odom_model(drive):
    """The odometry model a robot of this drive gets by default: skid for the skid-steer
    base (diff), ideal for the mecanum one (omni)."""
    return "skid" if drive == "diff" else "ideal"


class Simulation:
    """Robots in a world, stepped in simulated time.

    world: a World; seed: int for every random draw (odometry drift, laser noise);
    docks: charging docks [(x, y, yaw)] [m, m, rad], maybe none; dock_radius [m]: a
    robot standing still this close to a dock's (x, y) charges.
    """

    def __init__(self, world, seed=0, docks=(), dock_radius=0.3):
        self.world = world
        self.time = 0.0
        self.robots = {}
        self._seed = seed
        self._samples = {}
        self.docks = [tuple(float(v) for v in d) for d in docks]
        if not (math.isfinite(dock_radius) and dock_radius > 0.0):
            raise WorldError(f"dock_radius must be > 0 [m], got {dock_radius!r}")
        self.dock_radius = float(dock_radius)

    # -- robots -------------------------------------------------------------------
    def add_robot(self, name, x, y, yaw, drive="diff", params=None, laser=None, battery=None,
                  odom_model=None, imu=None):
        """Spawn a robot; WorldError naming it when the pose is off the map or blocked.

        battery: its Battery (default: a full pack with BatteryParams' defaults).
        odom_model: robot.ODOM_MODELS; None: default_odom_model(drive).
        imu: an imu.ImuSpec to carry an IMU (imu.ImuModel, seeded from the simulation's
        seed and the robot's index, its own stream: the other draws do not change), or None.
        """
        if name in self.robots:
            raise WorldError(f"robot '{name}' already exists")
        if drive not in DRIVES:
            raise WorldError(f"robot '{name}': drive must be one of {DRIVES}, got {drive!r}")
        odom_model = default_odom_model(drive) if odom_model is None else odom_model
        if odom_model not in rb.ODOM_MODELS:
            raise WorldError(f"robot '{name}': odom_model must be one of {rb.ODOM_MODELS}, got {odom_model!r}")
        if odom_model == "skid" and drive != "diff":
            raise WorldError(f"robot '{name}': odom_model skid is the skid-steer base's; drive {drive} "
                             f"(mecanum) takes odom_model ideal")
        params = params or rb.RobotParams()
        laser = laser or LaserParams()
        try:
            range_model = make_laser_model(laser.model, laser.noise_sigma)
        except ValueError as e:
            raise WorldError(f"robot '{name}': {e}") from None
        state = RobotState(name=name, drive=drive, params=params, laser=laser,
                           pose=(float(x), float(y), geometry.wrap_angle(float(yaw))),
                           rng=np.random.default_rng([self._seed, len(self.robots)]),
                           skid_rng=np.random.default_rng([self._seed, len(self.robots), SKID_STREAM]),
                           odom_model=odom_model, range_model=range_model, battery=battery or Battery())
        if imu is not None:
            state.imu = ImuModel(imu, np.random.default_rng([self._seed, len(self.robots), IMU_STREAM]))
        self._check_free(state, state.pose, spawning=True)
        self.robots[name] = state
        return state

    def _footprint_points(self, params):
        key = (params.length, params.width)
        if key not in self._samples:
            self._samples[key] = rb.footprint_samples(params, self.world.resolution / 2.0)
        return self._samples[key]

    def blocked_by(self, state, pose):
        """What the footprint at ``pose`` would hit: None, 'wall', 'box <name>', 'robot <name>'."""
        x, y, yaw = pose
        # Cheap gate: far from every wall cell no footprint point can be in one.
        if self.world.clearance(x, y) <= state.params.circumradius + self.world.resolution:
            pts = geometry.transform_points(self._footprint_points(state.params), (x, y, yaw))
            if self.world.points_hit_walls(pts):
                return "wall"
        rect = (x, y, yaw, state.params.length / 2.0, state.params.width / 2.0)
        reach = state.params.circumradius
        for name, box in self.world.boxes.items():
            if math.hypot(box[0] - x, box[1] - y) <= reach + math.hypot(box[3], box[4]):
                if rects_overlap(rect, box):
                    return f"box {name}"
        for other in self.robots.values():
            if other is state:
                continue
            if math.hypot(other.pose[0] - x, other.pose[1] - y) <= reach + other.params.circumradius:
                if rects_overlap(rect, other.rect()):
                    return f"robot {other.name}"
        return None

    def _check_free(self, state, pose, spawning=False):
        x, y, yaw = pose
        if not all(math.isfinite(v) for v in pose):
            raise WorldError(f"robot '{state.name}': pose ({x}, {y}, {yaw}) is not finite")
        if not self.world.on_map(x, y):
            xmin, ymin, xmax, ymax = self.world.bounds()
            raise WorldError(f"robot '{state.name}': pose ({x:.2f}, {y:.2f}) is off the map "
                             f"(x {xmin:.2f}..{xmax:.2f}, y {ymin:.2f}..{ymax:.2f})")
        what = self.blocked_by(state, pose)
        if what is not None:
            verb = "spawn" if spawning else "place"
            raise WorldError(f"robot '{state.name}': cannot {verb} at ({x:.2f}, {y:.2f}, "
                             f"{math.degrees(yaw):.1f} deg): the footprint overlaps a {what}")

    def set_pose(self, name, x, y, yaw):
        """Teleport a robot (ground truth only; odometry does not see it, as a kidnapping)."""
        state = self.robot(name)
        pose = (float(x), float(y), geometry.wrap_angle(float(yaw)))
        self._check_free(state, pose)
        state.pose = pose
        state.vel = (0.0, 0.0, 0.0)
        state.in_contact = False
        state.free_travel = 0.0

    def add_box(self, name, cx, cy, yaw, size_x, size_y):
        """Add or move a box [m, rad]; WorldError when it would overlap a robot."""
        box = (float(cx), float(cy), float(yaw), float(size_x) / 2.0, float(size_y) / 2.0)
        for state in self.robots.values():
            if math.isfinite(box[0] + box[1] + box[2]) and rects_overlap(state.rect(), box):
                raise WorldError(f"box '{name}' would overlap robot '{state.name}'")
        self.world.add_box(name, cx, cy, yaw, size_x, size_y)

    def robot(self, name):
        """The RobotState called ``name``; WorldError listing the robots otherwise."""
        if name not in self.robots:
            raise WorldError(f"no robot named '{name}' (robots: {', '.join(self.robots)})")
        return self.robots[name]

    def command(self, name, vx, vy, wz):
        """Accept a body-velocity command; returns None, or why it was ignored."""
        state = self.robot(name)
        vx, vy, wz, problem = rb.sanitize_command(state.params, state.drive, vx, vy, wz)
        if problem:
            return problem
        state.cmd = (vx, vy, wz)
        state.last_cmd_time = self.time
        return None

    # -- time -----------------------------------------------------------------------
    def step(self, dt):
        """Advance every robot by dt [s] of simulated time."""
        self.time += dt
        for state in self.robots.values():
            before = state.vel
            self._move(state, dt)
            if state.imu is not None:
                state.imu.accumulate(before, state.vel, dt)

    def _move(self, state, dt):
        """One robot's step: velocity, battery, collision check, pose and odometry."""
        cmd = state.cmd
        battery = state.battery
        skid = state.odom_model == "skid"
        if skid:
            state.skid_scale = rb.skid_scale_step(state.params, state.skid_scale, dt, state.skid_rng)
        if self.time - state.last_cmd_time > state.params.cmd_timeout or battery.empty:
            cmd = (0.0, 0.0, 0.0)  # watchdog: stale command; or the pack cut the motors
        vel = rb.step_velocity(state.params, state.vel, cmd, dt)
        # The pack sees the velocity the robot is asked to reach this step (a blocked
        # move stalls the motors at that load for the step).
        speed = math.hypot(vel[0], vel[1])
        battery.step(dt, speed, vel[2],
                     bool(self.docks) and near_dock(state.pose[0], state.pose[1], self.docks, self.dock_radius))
        if vel == (0.0, 0.0, 0.0):
            state.vel = vel
            state.odom_vel = vel
            return
        new_pose = rb.integrate_pose(state.pose, vel, dt)
        hit = self.blocked_by(state, new_pose)
        if hit is not None:
            if not state.in_contact:
                state.collisions += 1
                state.last_hit = hit
            state.in_contact = True
            state.free_travel = 0.0
            state.vel = (0.0, 0.0, 0.0)
            state.odom_vel = state.vel
            return
        inc = tuple(geometry.relative(state.pose, new_pose))
        state.free_travel += math.hypot(inc[0], inc[1]) + abs(inc[2]) * state.params.circumradius
        if state.free_travel > CONTACT_RESET:
            state.in_contact = False
        if skid:
            odom_inc = rb.skid_increment(state.params, inc, vel[2], state.skid_scale, state.rng)
            state.odom_vel = rb.skid_twist(state.params, vel, state.skid_scale)
            state.odom_budget = rb.skid_pose_budget_step(state.params, state.odom_budget, inc, vel[2])
        else:
            odom_inc = rb.noisy_increment(state.params, inc, state.rng)
            state.odom_vel = vel
        state.odom_pose = tuple(geometry.compose(state.odom_pose, odom_inc))
        state.pose = new_pose
        state.vel = vel

    def odom_covariance(self, name):
        """Diagonal variances of robot ``name``'s odometry: ((x, y, yaw) of the pose,
        (vx, vy, wz) of the twist) [m^2, rad^2, m^2/s^2, rad^2/s^2] for odom_model skid
        (robot.skid_pose_covariance, robot.skid_twist_covariance); None for ideal, whose
        messages carry no covariance."""
        state = self.robot(name)
        if state.odom_model != "skid":
            return None
        return rb.skid_pose_covariance(state.odom_budget), rb.skid_twist_covariance(state.params, state.vel)

    # -- sensing ----------------------------------------------------------------------
    def laser_pose(self, state):
        """World pose (x, y, yaw) of the robot's laser."""
        mx, my, myaw = state.laser.mount
        return tuple(geometry.compose(state.pose, (mx, my, myaw)))

    def scan(self, name, noise=True):
        """One laser scan of robot ``name``: ranges (n_beams,) float32 [m].

        The robot's range model (LaserParams.model) turns the exact ranges into what the
        scanner reports; noise=False gives the exact ranges. Beams with no return within
        range_max report +inf (REP 117); other ranges are clipped to [range_min, range_max].
        """
        state = self.robot(name)
        lx, ly, lyaw = self.laser_pose(state)
        laser = state.laser
        others = [o.rect() for o in self.robots.values() if o is not state]
        angles = laser.angles() + lyaw
        if noise and state.range_model.needs_incidence:
            ranges, cos_incidence = self.world.cast_hits(lx, ly, angles, laser.range_max, others)
        else:
            ranges = self.world.cast(lx, ly, angles, laser.range_max, others)
            cos_incidence = None
        if not noise:
            return report(ranges, laser.range_min, laser.range_max, ranges >= laser.range_max)
        return state.range_model.measure(ranges, cos_incidence, laser.angle_increment,
                                         laser.range_min, laser.range_max, state.rng)
