"""Simulated IMU: a Bosch BMI088 (3-axis gyroscope + 3-axis accelerometer) on the robot.

Datasheet (Bosch Sensortec, "BMI088 6-axis Motion Tracking for High-performance
Applications", BST-BMI088-DS001, rev. 1.3/1.4, 2018), the figures used:
  gyroscope      rate noise density 0.014 deg/s/sqrt(Hz); bias stability 2 deg/h;
                 range up to +-2000 deg/s
  accelerometer  noise density 175 ug/sqrt(Hz); range up to +-24 g
The sheet gives no in-run bias stability for the accelerometer; 40 ug is assumed (the
order of the Allan-variance floor of MEMS accelerometers of this class; an assumption,
not the datasheet's). The turn-on offsets the sheet lists are taken as removed by the
usual stand-still calibration at start-up; what is left is the in-run bias below.

Error model per axis and sample (the "IMU noise model" of Kalibr / Woodman 2007, "An
introduction to inertial navigation", UCAM-CL-TR-696), at the output rate f [Hz]:
  measured = true + b(t) + n,  n ~ N(0, (N sqrt(f))^2)  with N the noise density,
  b(t) a first-order Gauss-Markov process (correlation time BIAS_TAU), started from its
  stationary law, whose sigma is set so that its Allan-deviation peak (0.618 sigma, at
  1.89 tau) equals the IEEE-952 reading of the bias instability B (the Allan floor is
  0.664 B): sigma = 0.664 / 0.618 B = 1.07 B.

What the body really does (Simulation feeds every simulation step through accumulate):
the IMU sits at a lever arm r from base_footprint (its URDF mount), so the specific
force it measures in its frame is a + wdot x r + w x (w x r) - g, with a the body
origin's acceleration in the rotating body frame (vdot + w x v: the centripetal term of
a turn), the tangential term of an angular acceleration, and gravity: a level IMU at rest
reads +9.80665 m/s^2 on z. A sample reports the mean over its period (the delta-angle /
delta-velocity an IMU integrates internally), clipped to the range.

Orientation, as an AHRS without magnetometer reports it: yaw integrates the measured
z rate from 0 at start (it drifts with the noise and the bias: no magnetometer), roll and
pitch are 0 with the accelerometer's tilt noise (sigma / g per sample; the robot stays
level). Covariances are the model's own: angular velocity and linear acceleration, the
white noise variance at the rate plus the bias variance; orientation, roll and pitch the
tilt noise variance, yaw the integrated noise and bias: N^2 t + 2 sigma^2 tau^2 (t/tau - 1
+ exp(-t/tau)) after t [s].
"""
import math
from dataclasses import dataclass

import numpy as np

GRAVITY = 9.80665                 # [m/s^2] standard gravity
MICRO_G = 1e-6 * GRAVITY          # [m/s^2]
DEG = math.pi / 180.0             # [rad]
# Allan deviation: IEEE-952 bias instability B reads the floor as 0.664 B; a first-order
# Gauss-Markov process of sigma s peaks at 0.618 s.
GM_SIGMA_PER_BIAS_INSTABILITY = 0.664 / 0.618


@dataclass(frozen=True)
class ImuSpec:
    """A MEMS IMU's error figures (defaults: the BMI088's, see the module docstring) and
    where it sits on the robot."""

    gyro_noise_density: float = 0.014 * DEG          # [rad/s/sqrt(Hz)]
    gyro_bias_instability: float = 2.0 * DEG / 3600  # [rad/s]
    accel_noise_density: float = 175.0 * MICRO_G     # [m/s^2/sqrt(Hz)]
    accel_bias_instability: float = 40.0 * MICRO_G   # [m/s^2] (assumed, see above)
    bias_tau: float = 100.0                          # [s] correlation time of the biases
    gyro_range: float = 2000.0 * DEG                 # [rad/s]
    accel_range: float = 24.0 * GRAVITY              # [m/s^2]
    rate: float = 100.0                              # [Hz] output rate
    mount: tuple = (0.0, 0.0, 0.0)                   # (x [m], y [m], yaw [rad]) in base_footprint

    def gyro_white_sd(self):
        """Standard deviation [rad/s] of one gyroscope sample's white noise."""
        return self.gyro_noise_density * math.sqrt(self.rate)

    def accel_white_sd(self):
        """Standard deviation [m/s^2] of one accelerometer sample's white noise."""
        return self.accel_noise_density * math.sqrt(self.rate)

    def gyro_bias_sd(self):
        """Stationary sigma [rad/s] of the gyroscope's Gauss-Markov bias."""
        return GM_SIGMA_PER_BIAS_INSTABILITY * self.gyro_bias_instability

    def accel_bias_sd(self):
        """Stationary sigma [m/s^2] of the accelerometer's Gauss-Markov bias."""
        return GM_SIGMA_PER_BIAS_INSTABILITY * self.accel_bias_instability

    def tilt_sd(self):
        """Standard deviation [rad] of roll and pitch taken from one accelerometer sample."""
        return self.accel_white_sd() / GRAVITY

    def yaw_variance(self, t):
        """Variance [rad^2] of the integrated yaw t [s] after start: angle random walk
        plus the integrated Gauss-Markov bias."""
        tau, sb = self.bias_tau, self.gyro_bias_sd()
        return self.gyro_noise_density ** 2 * t + 2.0 * sb * sb * tau * tau * (t / tau - 1.0 + math.exp(-t / tau))

    def check(self):
        """ValueError naming the first figure that cannot be used."""
        for name in ("gyro_noise_density", "gyro_bias_instability", "accel_noise_density",
                     "accel_bias_instability"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"imu {name} must be >= 0, got {v!r}")
        for name in ("bias_tau", "gyro_range", "accel_range", "rate"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"imu {name} must be > 0, got {v!r}")


@dataclass
class ImuSample:
    """One IMU message's content, in the IMU's frame."""

    stamp: float                 # [s] simulated time at the end of the sample's period
    roll: float                  # [rad]
    pitch: float                 # [rad]
    yaw: float                   # [rad] integrated from 0 at start, wrapped to (-pi, pi]
    angular_velocity: tuple      # (x, y, z) [rad/s]
    linear_acceleration: tuple   # (x, y, z) [m/s^2], specific force (+g on z at rest)
    orientation_variance: tuple  # (roll, pitch, yaw) [rad^2]
    angular_velocity_variance: float    # [rad^2/s^2] per axis
    linear_acceleration_variance: float  # [m^2/s^4] per axis


def body_specific_force(v0, v1, dt, lever):
    """Mean specific force (x, y, z) [m/s^2] in base_footprint's axes at the point lever
    (x, y) [m] over a simulation step of dt [s] in which the body velocity (vx, vy, wz)
    changed from v0 to v1. The simulator's kinematics (robot.integrate_pose) hold v1
    through the step, so the change is an impulse (v1 - v0) / dt and the rotating-frame
    terms take v1: origin acceleration vdot + w x v, tangential wdot x r, centripetal
    w x (w x r); minus gravity (so +g on z)."""
    vx, vy, wz = v1
    ax = (v1[0] - v0[0]) / dt - wz * vy
    ay = (v1[1] - v0[1]) / dt + wz * vx
    wdot = (v1[2] - v0[2]) / dt
    rx, ry = lever
    ax += -wdot * ry - wz * wz * rx
    ay += wdot * rx - wz * wz * ry
    return ax, ay, GRAVITY


class ImuModel:
    """The IMU of one robot: Simulation.step feeds it the true body velocity every step
    (accumulate); the node takes a sample at the IMU's rate (sample).

    spec: ImuSpec; rng: numpy Generator of its own (every sample draws the same number of
    normals: 14).
    """

    DRAWS_PER_SAMPLE = 14   # 3 gyro noise, 3 accel noise, 3 + 3 bias steps, roll, pitch

    def __init__(self, spec, rng):
        spec.check()
        self.spec = spec
        self.rng = rng
        self.gyro_bias = rng.standard_normal(3) * spec.gyro_bias_sd()
        self.accel_bias = rng.standard_normal(3) * spec.accel_bias_sd()
        self.time = 0.0              # [s] since start
        self.yaw = 0.0               # [rad] integrated, unwrapped
        self._mx, self._my, myaw = spec.mount
        self._cos, self._sin = math.cos(myaw), math.sin(myaw)
        self._angle = 0.0            # [rad] true z rotation since the last sample
        self._dv = np.zeros(3)       # [m/s] integrated specific force (base axes) since the last sample
        self._elapsed = 0.0          # [s] since the last sample

    def accumulate(self, v0, v1, dt):
        """One simulation step of dt [s] in which the body velocity (vx, vy, wz) went
        from v0 to v1."""
        fx, fy, fz = body_specific_force(v0, v1, dt, (self._mx, self._my))
        self._dv[0] += fx * dt
        self._dv[1] += fy * dt
        self._dv[2] += fz * dt
        self._angle += v1[2] * dt   # as robot.integrate_pose turns the body
        self._elapsed += dt

    def sample(self):
        """The sample over the steps accumulated since the last one (ImuSample); None
        when no time has passed."""
        dt = self._elapsed
        if dt <= 0.0:
            return None
        spec = self.spec
        z = self.rng.standard_normal(self.DRAWS_PER_SAMPLE)
        tau = spec.bias_tau
        phi = math.exp(-dt / tau)
        self.gyro_bias = phi * self.gyro_bias + spec.gyro_bias_sd() * math.sqrt(1.0 - phi * phi) * z[6:9]
        self.accel_bias = phi * self.accel_bias + spec.accel_bias_sd() * math.sqrt(1.0 - phi * phi) * z[9:12]
        # White noise of a sample taken at this period: density * sqrt(1 / period).
        gyro_sd = spec.gyro_noise_density / math.sqrt(dt)
        accel_sd = spec.accel_noise_density / math.sqrt(dt)
        wz = self._angle / dt
        gyro = np.array([0.0, 0.0, wz]) + self.gyro_bias + gyro_sd * z[0:3]
        fx, fy, fz = self._dv / dt
        # Into the IMU's axes (mounted level, turned by its yaw about z).
        f = np.array([self._cos * fx + self._sin * fy, -self._sin * fx + self._cos * fy, fz])
        accel = f + self.accel_bias + accel_sd * z[3:6]
        np.clip(gyro, -spec.gyro_range, spec.gyro_range, out=gyro)
        np.clip(accel, -spec.accel_range, spec.accel_range, out=accel)
        self.time += dt
        self.yaw += gyro[2] * dt
        tilt_sd = accel_sd / GRAVITY
        self._angle, self._elapsed = 0.0, 0.0
        self._dv[:] = 0.0
        return ImuSample(stamp=self.time, roll=tilt_sd * z[12], pitch=tilt_sd * z[13],
                         yaw=math.remainder(self.yaw, 2.0 * math.pi),
                         angular_velocity=tuple(float(v) for v in gyro),
                         linear_acceleration=tuple(float(v) for v in accel),
                         orientation_variance=(tilt_sd ** 2, tilt_sd ** 2, spec.yaw_variance(self.time)),
                         angular_velocity_variance=gyro_sd ** 2 + spec.gyro_bias_sd() ** 2,
                         linear_acceleration_variance=accel_sd ** 2 + spec.accel_bias_sd() ** 2)
