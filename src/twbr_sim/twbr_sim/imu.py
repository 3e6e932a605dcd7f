"""What an IMU on the axle centre, aligned with base_link, reports: orientation (unless raw), body rates and
specific force including gravity; ideal by default, or like hardware: white noise, a bias drawn at start-up
that then walks, a reading delay, and no orientation at all (raw mode, as MPU-6050 / BMI088 / ICM-42688
class parts, whose driver leaves orientation_covariance[0] = -1).

base_link is pitched with the body (roll 0, pitch theta, yaw psi), so its x axis tips forward-down
when the body leans forward. `imu_sample` is the one implementation: the simulator and the batch engine
call it once per published state, on a settings vector (I_*), a memory vector (M_*) and a generator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_sim.dynamics import S_PSI, S_PSID, S_TH, S_THD, S_XD
from twbr_sim.noise import new_generator, normal
from twbr_sim.robot_params import P_G

IMU_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("imu.raw", False, "publish no orientation (orientation_covariance[0] = -1), only angular velocity"
              " and linear acceleration, as a raw MEMS IMU: the controller then estimates pitch"),
    ParamSpec("imu.gyro_noise_std", 0.0, "white noise on each angular rate, per reading", "rad/s", 0.0, 10.0),
    ParamSpec("imu.gyro_bias_std", 0.0, "std of the gyro bias drawn at start-up", "rad/s", 0.0, 10.0),
    ParamSpec("imu.gyro_bias_walk", 0.0, "random walk of the gyro bias (rate random walk)", "rad/s/√s", 0.0, 1.0),
    ParamSpec("imu.accel_noise_std", 0.0, "white noise on each specific-force axis, per reading", "m/s^2", 0.0,
              100.0),
    ParamSpec("imu.accel_bias_std", 0.0, "std of the accelerometer bias drawn at start-up", "m/s^2", 0.0, 100.0),
    ParamSpec("imu.accel_bias_walk", 0.0, "random walk of the accelerometer bias", "m/s^2/√s", 0.0, 10.0),
    ParamSpec("imu.orientation_noise_std", 0.0, "white noise on roll, pitch and yaw of the orientation", "rad",
              0.0, 1.0),
    ParamSpec("imu.pitch_bias", 0.0, "constant pitch offset of the mounting (a miscalibrated IMU)", "rad", -0.5, 0.5),
    ParamSpec("imu.delay", 0.0, "age of each reading when published (the part's filter and the bus), in whole"
              " publish periods (rounded)", "s", 0.0, 0.1),
)
IMU_STREAM = 1  # the IMU's generator stream (noise.new_generator)

SETTINGS_LAYOUT = Layout((
    "period", "gyro_noise", "gyro_bias_std", "gyro_bias_walk", "accel_noise", "accel_bias_std", "accel_bias_walk",
    "orientation_noise", "pitch_bias", "delay_samples",
))
I_PERIOD = SETTINGS_LAYOUT["period"]
I_GYRO_NOISE = SETTINGS_LAYOUT["gyro_noise"]
I_GYRO_BIAS_STD = SETTINGS_LAYOUT["gyro_bias_std"]
I_GYRO_WALK = SETTINGS_LAYOUT["gyro_bias_walk"]
I_ACCEL_NOISE = SETTINGS_LAYOUT["accel_noise"]
I_ACCEL_BIAS_STD = SETTINGS_LAYOUT["accel_bias_std"]
I_ACCEL_WALK = SETTINGS_LAYOUT["accel_bias_walk"]
I_ORIENTATION_NOISE = SETTINGS_LAYOUT["orientation_noise"]
I_PITCH_BIAS = SETTINGS_LAYOUT["pitch_bias"]
I_DELAY = SETTINGS_LAYOUT["delay_samples"]
N_SETTINGS = len(SETTINGS_LAYOUT)
# One reading: orientation (roll, pitch, yaw) [rad], angular velocity [rad/s], specific force [m/s^2].
READING_LAYOUT = Layout(("roll", "pitch", "yaw", ("gyro", 3), ("accel", 3)))
RD_ROLL = READING_LAYOUT["roll"]
RD_PITCH = READING_LAYOUT["pitch"]
RD_YAW = READING_LAYOUT["yaw"]
RD_GYRO = READING_LAYOUT["gyro"]
RD_ACCEL = READING_LAYOUT["accel"]
N_READING = len(READING_LAYOUT)
# Memory: the biases now, readings taken so far, then a ring of the last delay+1 ideal readings.
MEMORY_LAYOUT = Layout((("gyro_bias", 3), ("accel_bias", 3), "samples"))
IM_GYRO_BIAS = MEMORY_LAYOUT["gyro_bias"]
IM_ACCEL_BIAS = MEMORY_LAYOUT["accel_bias"]
IM_SAMPLES = MEMORY_LAYOUT["samples"]
IM_RING = len(MEMORY_LAYOUT)


@dataclass
class ImuReading:
    roll: float
    pitch: float
    yaw: float
    angular_velocity: tuple[float, float, float]
    linear_acceleration: tuple[float, float, float]

    @classmethod
    def of(cls, r: np.ndarray) -> ImuReading:
        g, a = RD_GYRO, RD_ACCEL
        return cls(float(r[RD_ROLL]), float(r[RD_PITCH]), float(r[RD_YAW]),
                   (float(r[g]), float(r[g + 1]), float(r[g + 2])), (float(r[a]), float(r[a + 1]), float(r[a + 2])))


def settings_vector(settings: dict, publish_rate: float) -> np.ndarray:
    """The IMU's parameters (IMU_SPECS) in the kernel's layout, for readings taken at `publish_rate` [Hz]."""
    s = settings
    return SETTINGS_LAYOUT.pack({
        "period": 1.0 / publish_rate, "gyro_noise": s["imu.gyro_noise_std"], "gyro_bias_std": s["imu.gyro_bias_std"],
        "gyro_bias_walk": s["imu.gyro_bias_walk"], "accel_noise": s["imu.accel_noise_std"],
        "accel_bias_std": s["imu.accel_bias_std"], "accel_bias_walk": s["imu.accel_bias_walk"],
        "orientation_noise": s["imu.orientation_noise_std"], "pitch_bias": s["imu.pitch_bias"],
        "delay_samples": round(s["imu.delay"] * publish_rate),
    })


def new_memory(c: np.ndarray) -> np.ndarray:
    return np.zeros(IM_RING + (int(c[I_DELAY]) + 1) * N_READING)


@kernel
def ideal_imu(p, s, ds, out):
    """Noise-free reading from state `s` and its derivative `ds` (for the accelerations), into `out` (R_*)."""
    pitch = s[S_TH]
    sn = math.sin(pitch)
    cs = math.cos(pitch)
    yaw_rate = s[S_PSID]
    out[RD_ROLL] = 0.0
    out[RD_PITCH] = pitch
    out[RD_YAW] = s[S_PSI]
    # Body rates: the yaw rate is about world z, which in the pitched body frame is (-sin, 0, cos).
    out[RD_GYRO] = -sn * yaw_rate
    out[RD_GYRO + 1] = s[S_THD]
    out[RD_GYRO + 2] = cs * yaw_rate
    # Specific force of the axle centre in the heading frame: forward accel, centripetal, +g; then rotated
    # into the pitched body frame.
    g = p[P_G]
    a_fwd = ds[S_XD]
    out[RD_ACCEL] = cs * a_fwd - sn * g
    out[RD_ACCEL + 1] = s[S_XD] * yaw_rate
    out[RD_ACCEL + 2] = sn * a_fwd + cs * g


@kernel
def imu_init(c, m, g):
    """The start-up biases (drawn only where their std is set, so an ideal IMU draws nothing)."""
    for i in range(3):
        m[IM_GYRO_BIAS + i] = c[I_GYRO_BIAS_STD] * normal(g) if c[I_GYRO_BIAS_STD] > 0.0 else 0.0
        m[IM_ACCEL_BIAS + i] = c[I_ACCEL_BIAS_STD] * normal(g) if c[I_ACCEL_BIAS_STD] > 0.0 else 0.0


@kernel
def _add_noise(out, first, count, std, g):
    if std > 0.0:
        for i in range(first, first + count):
            out[i] += std * normal(g)


@kernel
def imu_sample(p, c, m, g, s, ds, out):
    """The reading published with state `s` (one call per published state, in order), into `out` (R_*)."""
    slot = _ring_slot(c, m)
    ideal_imu(p, s, ds, m[slot:slot + N_READING])
    _report(c, m, g, out)


@kernel
def imu_sample_of(c, m, g, ideal, out):
    """imu_sample for an ideal reading `ideal` (R_*) measured elsewhere (another physics engine's sensors)."""
    slot = _ring_slot(c, m)
    m[slot:slot + N_READING] = ideal
    _report(c, m, g, out)


@kernel
def _ring_slot(c, m):
    return IM_RING + (int(m[IM_SAMPLES]) % (int(c[I_DELAY]) + 1)) * N_READING


@kernel
def _report(c, m, g, out):
    """The reading due now from the ring (the delay), with bias, its walk and noise; counts the sample."""
    delay = int(c[I_DELAY])
    n = int(m[IM_SAMPLES])
    # Before `delay` readings exist, the part reports its first one.
    old = IM_RING + ((n - delay) % (delay + 1) if n >= delay else 0) * N_READING
    out[:] = m[old:old + N_READING]
    m[IM_SAMPLES] = n + 1
    step = math.sqrt(c[I_PERIOD])
    for i in range(3):
        if c[I_GYRO_WALK] > 0.0:
            m[IM_GYRO_BIAS + i] += c[I_GYRO_WALK] * step * normal(g)
        if c[I_ACCEL_WALK] > 0.0:
            m[IM_ACCEL_BIAS + i] += c[I_ACCEL_WALK] * step * normal(g)
        out[RD_GYRO + i] += m[IM_GYRO_BIAS + i]
        out[RD_ACCEL + i] += m[IM_ACCEL_BIAS + i]
    out[RD_PITCH] += c[I_PITCH_BIAS]
    _add_noise(out, RD_GYRO, 3, c[I_GYRO_NOISE], g)
    _add_noise(out, RD_ACCEL, 3, c[I_ACCEL_NOISE], g)
    _add_noise(out, RD_ROLL, 3, c[I_ORIENTATION_NOISE], g)


class ImuModel:
    """One IMU: its settings, memory and generator, around the kernels."""

    def __init__(self, settings: dict, seed: int, publish_rate: float) -> None:
        self.raw = bool(settings["imu.raw"])
        self.c = settings_vector(settings, publish_rate)
        self.m = new_memory(self.c)
        self.g = new_generator(seed, IMU_STREAM)
        self._out = np.zeros(N_READING)
        imu_init(self.c, self.m, self.g)

    def read(self, p: np.ndarray, s: np.ndarray, ds: np.ndarray) -> ImuReading:
        """The next reading (each call is one more sample of the part)."""
        imu_sample(p, self.c, self.m, self.g, s, ds, self._out)
        return ImuReading.of(self._out)

    def read_ideal(self, ideal: np.ndarray) -> ImuReading:
        """The next reading, from an ideal one (R_* layout) that another engine measured."""
        imu_sample_of(self.c, self.m, self.g, ideal, self._out)
        return ImuReading.of(self._out)


def ideal_reading(p: np.ndarray, s: np.ndarray, ds: np.ndarray) -> ImuReading:
    out = np.zeros(N_READING)
    ideal_imu(p, s, ds, out)
    return ImuReading.of(out)
