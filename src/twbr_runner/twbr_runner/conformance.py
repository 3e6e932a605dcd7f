"""The checks of a robot driver against docs/interfaces.md, on recorded samples (plain Python).

check_driver (the node) collects what the driver publishes while it answers each state with a torque
command, then these functions judge it. Each returns a Check: a name, pass/fail and one line of detail.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

ODOM_FRAME = "odom"
BASE_FRAME = "base_link"
WHEEL_JOINTS = ("left_wheel_joint", "right_wheel_joint")
SENSOR_TOPICS = {
    "odom": "nav_msgs/msg/Odometry",
    "imu": "sensor_msgs/msg/Imu",
    "joint_states": "sensor_msgs/msg/JointState",
}
COMMAND_TOPIC = ("wheel_torque_cmd", "twbr_msgs/msg/WheelTorques")
SCAN_TOPIC = ("scan", "sensor_msgs/msg/LaserScan")


@dataclass(frozen=True)
class ScanSample:
    """What the scan checks read of one sensor_msgs/LaserScan."""

    frame: str
    angle_min: float
    angle_max: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: tuple[float, ...]


@dataclass(frozen=True)
class Check:
    name: str
    passed: bool
    detail: str

    def line(self) -> str:
        return f"{'PASS' if self.passed else 'FAIL'}  {self.name}: {self.detail}"


def check_type(topic: str, expected: str, offered: Sequence[str], role: str) -> Check:
    name = f"{topic} type"
    if not offered:
        return Check(name, False, f"no {role} of {topic}")
    if list(offered) != [expected]:
        return Check(name, False, f"{role} offers {', '.join(offered)}; the contract says {expected}")
    return Check(name, True, expected)


def check_stamps(topic: str, stamps: Sequence[float]) -> Check:
    """Every stamp set (zero stamps are allowed only before the first non-zero one: a simulator at t = 0,
    maybe offering its first state again) and never going back."""
    name = f"{topic} stamps"
    if len(stamps) < 2:
        return Check(name, False, f"{len(stamps)} message(s) received")
    first_set = next((k for k, t in enumerate(stamps) if t != 0.0), len(stamps))
    unstamped = sum(1 for t in stamps[first_set:] if t == 0.0) + (len(stamps) if first_set == len(stamps) else 0)
    if unstamped:
        return Check(name, False, f"{unstamped} of {len(stamps)} messages have no stamp")
    back = sum(1 for a, b in itertools.pairwise(stamps) if b < a)
    if back:
        return Check(name, False, f"{back} stamps go back in time")
    if stamps[-1] <= stamps[0]:
        return Check(name, False, "stamps never advance")
    return Check(name, True, f"{len(stamps)} messages, stamps set and monotonic")


def check_rate(topic: str, stamps: Sequence[float], expected: float, tolerance: float) -> Check:
    """The publication rate in the driver's own time (its stamps: sim time or wall time alike): samples
    received per second of stamps, so a driver that skips samples fails as one that runs slow does. Gaps
    of more than 1.5 periods are counted in the detail: they tell skipped samples from a slow clock."""
    name = f"{topic} rate"
    distinct = sorted(set(stamps))
    if len(distinct) < 3:
        return Check(name, False, "too few distinct stamps to measure a rate")
    rate = (len(distinct) - 1) / (distinct[-1] - distinct[0])
    ok = abs(rate - expected) <= tolerance * expected
    gaps = sum(1 for a, b in itertools.pairwise(distinct) if (b - a) * expected > 1.5)
    detail = f"{rate:.1f} Hz (expected {expected:g} Hz ± {tolerance:.0%})"
    return Check(name, ok, detail + (f"; {gaps} gap(s) longer than 1.5 periods" if gaps else ""))


def check_frames(odom_frames: set[tuple[str, str]], imu_frames: set[str], joint_names: set[tuple[str, ...]]) -> Check:
    problems = []
    if odom_frames != {(ODOM_FRAME, BASE_FRAME)}:
        problems.append(f"odom frames {sorted(odom_frames)} (expected {ODOM_FRAME} -> {BASE_FRAME})")
    if imu_frames != {BASE_FRAME}:
        problems.append(f"imu frame {sorted(imu_frames)} (expected {BASE_FRAME})")
    if any(not set(WHEEL_JOINTS) <= set(names) for names in joint_names) or not joint_names:
        problems.append(f"joint names {sorted(joint_names)} (expected {', '.join(WHEEL_JOINTS)})")
    return Check("frames", not problems, "; ".join(problems) or f"{ODOM_FRAME} -> {BASE_FRAME}, imu in"
                 f" {BASE_FRAME}, {', '.join(WHEEL_JOINTS)}")


def check_imu_kind(kinds: set[str]) -> Check:
    """Which IMU the driver has: one that reports an orientation, or a raw one (orientation_covariance[0] =
    -1, REP 145) whose pitch the controller estimates from gyro and accelerometer (pitch_source auto)."""
    if kinds == {"raw"}:
        return Check("imu kind", True, "raw: angular velocity and linear acceleration only (orientation_covariance[0]"
                     " = -1); the controller estimates pitch (pitch_source auto or estimator)")
    if kinds == {"orientation"}:
        return Check("imu kind", True, "orientation reported; the controller uses it (pitch_source auto or"
                     " orientation)")
    return Check("imu kind", False, f"mixed: {', '.join(sorted(kinds)) or 'no imu message'} (a driver's imu must be"
                 " raw in every message or in none)")


def check_qos(topic: str, compatible: Sequence[tuple[bool, str]]) -> Check:
    name = f"{topic} QoS"
    if not compatible:
        return Check(name, False, "no endpoint to match")
    bad = [reason for ok, reason in compatible if not ok]
    if bad:
        return Check(name, False, "; ".join(bad))
    return Check(name, True, f"{len(compatible)} endpoint(s) match our side")


def check_pitch_sign(v_before: float, v_after: float, pitch_before: float, pitch_after: float,
                     torque: float) -> Check:
    """A forward wheel torque speeds the wheels up and, by reaction, leans the body back: the odometry's
    speed rises while the IMU's pitch falls (pitch > 0 is leaning forward)."""
    dv, dpitch = v_after - v_before, pitch_after - pitch_before
    detail = f"+{torque:g} N·m on both wheels: speed {dv:+.4f} m/s, IMU pitch {dpitch:+.4f} rad"
    if dv <= 0.0:
        return Check("pitch sign vs odometry", False, detail + " (the odometry did not speed up)")
    if dpitch >= 0.0:
        return Check("pitch sign vs odometry", False, detail + " (pitch should fall: IMU sign or axis wrong)")
    return Check("pitch sign vs odometry", True, detail)


# Driver seconds a driver may take to show the commanded torque in joint_states' effort: check_driver times
# its pulse from that answer, so a driver whose host held it back (samples published late, in a burst) is
# judged on the pulse it applied, not on the command's way to it.
ANSWER_LIMIT_S = 1.0


def check_response(effort_before: float, effort_during: float, torque: float, latency: float | None) -> Check:
    """The commanded torque shows up in joint_states' effort (the motors' torque); `latency` is the driver's
    time from the command to that answer, None if it never came."""
    ok = effort_during > 0.5 * torque and effort_during > effort_before
    answered = f" (no answer within {ANSWER_LIMIT_S:g} s)" if latency is None else f", answered after {latency:.3f} s"
    return Check("response to wheel_torque_cmd", ok,
                 f"mean wheel effort {effort_before:+.3f} -> {effort_during:+.3f} N·m for +{torque:g} N·m commanded"
                 + answered)


def check_scan_fields(scans: Sequence[ScanSample]) -> Check:
    """Each scan's angles agree with its number of ranges, its limits are ordered, and its ranges follow
    REP 117: a measurement within [range_min, range_max], +inf for no return, -inf for too close, NaN only
    for an erroneous reading (counted here: a driver that reports misses as NaN or 0 loses its free space)."""
    name = "scan fields"
    if not scans:
        return Check(name, False, "no scan received")
    problems: list[str] = []
    for k, s in enumerate(scans):
        n = len(s.ranges)
        if n == 0:
            problems.append(f"scan {k}: no ranges")
            continue
        spanned = s.angle_min + (n - 1) * s.angle_increment
        if abs(spanned - s.angle_max) > max(1e-4, 0.5 * abs(s.angle_increment)):
            problems.append(f"scan {k}: angle_max {s.angle_max:.4f} rad, but angle_min + ({n} - 1) x"
                            f" angle_increment = {spanned:.4f} rad")
        if not 0.0 <= s.range_min < s.range_max:
            problems.append(f"scan {k}: range_min {s.range_min:g} m, range_max {s.range_max:g} m")
        nan = sum(1 for r in s.ranges if math.isnan(r))
        outside = sum(1 for r in s.ranges if math.isfinite(r) and not s.range_min <= r <= s.range_max)
        if nan or outside:
            problems.append(f"scan {k}: {nan} NaN and {outside} finite range(s) outside [range_min, range_max]"
                            " (REP 117: +inf no return, -inf too close)")
        if problems:
            break
    if problems:
        return Check(name, False, "; ".join(problems))
    s = scans[-1]
    returns = sum(1 for r in s.ranges if math.isfinite(r))
    return Check(name, True, f"{len(s.ranges)} beams, {math.degrees(s.angle_min):.0f} to"
                 f" {math.degrees(s.angle_max):.0f} degrees, {s.range_min:g}-{s.range_max:g} m; {returns} returns in"
                 " the last scan, the rest REP 117 infinities")


def check_scan_frame(frames: set[str], links: set[tuple[str, str]]) -> Check:
    """The scan's frame is one, and the transform tree (/tf_static or /tf) links it to base_link, directly
    or through other frames, as RViz and a tracker need to place its points."""
    name = "scan frame"
    if len(frames) != 1:
        return Check(name, False, f"frames {sorted(frames)} (expected one)")
    (frame,) = frames
    parents = {child: parent for parent, child in links}
    seen, at = [frame], frame
    while at in parents and at not in seen[:-1]:
        at = parents[at]
        seen.append(at)
        if at == BASE_FRAME:
            return Check(name, True, " <- ".join(seen))
    return Check(name, False, f"{frame!r} is not linked to {BASE_FRAME} by /tf_static or /tf"
                 f" (transforms seen: {sorted(links) or 'none'})")
