"""Scenario files (config/scenarios/*.yaml): the world set-up, time limit and command profile of a run.

Every field is checked against a range; a malformed file is refused with one message naming the field
by its path (e.g. `obstacles[1].radius`) and its valid range. Angles may be written as numbers [rad]
or as multiples of pi such as `3pi/4`.

A scenario may vary with the seed (`variation`): obstacles' and the target's start positions, the moving
obstacles' timing along their paths and their speeds are drawn per seed, so that a study of many seeds is
many layouts of one kind, not one layout many times. `vary(scenario, seed)` gives the seed's layout; the
world (sim_node, world_node, the headless runs) and the batch engine both build theirs with it.

A scenario may pin planner parameters (`planner`, e.g. `{method: paper}` in the paper's three scenarios,
which reproduce its results): every run of it uses them unless the caller sets the same parameter (the
runner's --planner-method, the suite's methods). They are checked against the planner's parameter table
where a run starts (twbr_planner.planner_params.resolve), not here: the simulator does not know them.
Likewise `perception` (lidar, the default, or truth, which the paper's three pin): where the runner's
planner takes its obstacles from, unless the caller says (--perception).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from twbr_common.jit import kernel
from twbr_common.params import ConfigError, ParamSpec
from twbr_sim.agents import MOTIONS, REACTIONS

_NAME_RE = re.compile(r"^[A-Za-z0-9_-][A-Za-z0-9_.-]{0,99}$")
_PI_RE = re.compile(r"^\s*(-?\d*\.?\d*)\s*\*?\s*pi\s*(?:/\s*(\d+\.?\d*))?\s*$")


def parse_angle(value: Any, where: str) -> Any:
    """Numbers pass through; strings like '3pi/4', '-pi/2', 'pi' become radians."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            pass
        m = _PI_RE.match(value)
        if not m:
            raise ConfigError(f"invalid field '{where}' = {value!r}: must be a number [rad] or like '3pi/4'")
        coef = m.group(1)
        k = -1.0 if coef == "-" else (1.0 if coef in ("", "+") else float(coef))
        divisor = float(m.group(2)) if m.group(2) else 1.0
        if divisor == 0.0:
            raise ConfigError(f"invalid field '{where}' = {value!r}: divides by zero; must be a number [rad] or"
                              " like '3pi/4'")
        return k * math.pi / divisor
    return value


@dataclass(frozen=True)
class TargetSpec:
    x: float
    y: float
    heading: float
    speed: float
    max_yaw_rate: float
    turn_interval: float
    capture_radius: float


@dataclass(frozen=True)
class MotionSpec:
    """How an obstacle moves other than on a straight line (twbr_sim.agents): its kind and its settings."""

    kind: str  # agents.MOTIONS
    speed: float  # [m/s] the speed it wants (wander: the middle of its draws)
    heading: float = 0.0  # [rad] wander: the start heading
    waypoints: tuple[tuple[float, float], ...] = ()  # [m]
    loop: bool = True
    pause: float = 0.0  # [s] at each waypoint
    max_yaw_rate: float = 0.0  # [rad/s]
    turn_interval: float = 1.0  # [s]
    speed_change: float = 0.0  # fraction of speed
    stop_probability: float = 0.0
    stop_time: float = 0.0  # [s]
    roam_radius: float = 0.0  # [m] 0: unbounded


@dataclass(frozen=True)
class ReactionSpec:
    """An obstacle that reacts to the robot and the others with a social force (twbr_sim.agents)."""

    attention: float = 1.0  # weight of the robot in its social force, 0-1
    strength: float = 2.1  # [m/s²] Helbing's A
    range: float = 0.3  # [m] Helbing's B
    relaxation_time: float = 0.5  # [s]
    anisotropy: float = 0.5  # lambda: weight of what is behind it


@dataclass(frozen=True)
class ObstacleSpec:
    """A circular obstacle: position [m] (at t = 0 in a scenario, now in World.obstacles()), velocity [m/s]
    (a scenario's: the straight kind's), and how it moves otherwise (None: straight, not reacting)."""

    id: int
    x: float
    y: float
    vx: float
    vy: float
    radius: float
    motion: MotionSpec | None = None
    reaction: ReactionSpec | None = None


@dataclass(frozen=True)
class CommandStep:
    """From time t on, the scenario asks for forward speed v [m/s] and yaw rate w [rad/s]."""

    t: float
    v: float
    w: float


@dataclass(frozen=True)
class Variation:
    """Per-seed changes of the layout, each drawn uniformly in +-its value (0: none)."""

    obstacle_position: float = 0.0  # [m] on each of x and y of each obstacle's start
    obstacle_timing: float = 0.0  # [s] an obstacle moving straight starts this much earlier or later on its path
    obstacle_speed: float = 0.0  # fraction of a moving obstacle's speed (every motion kind's)
    target_position: float = 0.0  # [m] on each of x and y of the target's start

    @property
    def any(self) -> bool:
        return any((self.obstacle_position, self.obstacle_timing, self.obstacle_speed, self.target_position))


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    duration: float
    seed: int
    start_x: float = 0.0
    start_y: float = 0.0
    start_yaw: float = 0.0
    start_pitch: float = 0.0
    target: TargetSpec | None = None
    obstacles: tuple[ObstacleSpec, ...] = ()
    commands: tuple[CommandStep, ...] = ()
    end_on_target: bool = False
    variation: Variation = Variation()
    planner: tuple[tuple[str, Any], ...] = ()  # planner parameters the scenario pins: (name, value)
    perception: str = "lidar"  # the planner's obstacles: "lidar" (scan -> tracker_node) or "truth" (the world's)
    source: str = field(default="", compare=False)


_BIG = 1e6
PERCEPTIONS = ("lidar", "truth")
_TOP = (
    ParamSpec("duration", 60.0, "time limit of the run", "s", 0.0, 86400.0, low_open=True),
    ParamSpec("seed", 0, "seed of the target's random turns (a node's seed parameter overrides it)", "", 0, 2**31 - 1),
    ParamSpec("end_on_target", False, "end the run when the target is reached"),
    ParamSpec("perception", "lidar", "what the planner's obstacles come from where a run starts: lidar (the"
              " simulated LiDAR through tracker_node, as a real robot) or truth (the world's own obstacles; the"
              " paper's three scenarios pin it)", choices=PERCEPTIONS),
)
_ROBOT = (
    ParamSpec("x", 0.0, "start x in odom", "m", -_BIG, _BIG),
    ParamSpec("y", 0.0, "start y in odom", "m", -_BIG, _BIG),
    ParamSpec("yaw", 0.0, "start heading", "rad", -math.pi, math.pi),
    ParamSpec("pitch", 0.0, "start pitch", "rad", -0.5, 0.5),
)
_TARGET = (
    ParamSpec("position", [0.0, 0.0], "start position [x, y] in odom", "m"),
    ParamSpec("heading", 0.0, "start heading", "rad", -2 * math.pi, 2 * math.pi),
    ParamSpec("speed", 0.0, "constant speed", "m/s", 0.0, 10.0),
    ParamSpec("max_yaw_rate", 0.0, "yaw rate drawn uniformly in +-max_yaw_rate", "rad/s", 0.0, 20.0),
    ParamSpec("turn_interval", 1.0, "time between yaw-rate draws", "s", 0.0, 1e4, low_open=True),
    ParamSpec("capture_radius", 0.5, "distance at which the target counts as reached", "m", 0.0, 100.0, low_open=True),
)
_OBSTACLE = (
    ParamSpec("id", 0, "obstacle id (unique)", "", 0, 2**31 - 1),
    ParamSpec("position", [0.0, 0.0], "start position [x, y] in odom", "m"),
    ParamSpec("radius", 1.0, "radius", "m", 0.0, 1000.0, low_open=True),
    ParamSpec("speed", 0.0, "speed (straight: constant; waypoints: along the route; wander: the middle of its"
              " draws)", "m/s", 0.0, 100.0),
    ParamSpec("heading", 0.0, "direction of motion (wander: at the start)", "rad", -2 * math.pi, 2 * math.pi),
    ParamSpec("motion", "straight", "straight (constant velocity), waypoints or wander (twbr_sim.agents)",
              choices=MOTIONS),
    ParamSpec("loop", True, "waypoints: start again at the first after the last (false: stop there)"),
    ParamSpec("pause", 0.0, "waypoints: time standing at each waypoint", "s", 0.0, 1e4),
    ParamSpec("max_yaw_rate", 0.0, "wander: yaw rate drawn uniformly in +-max_yaw_rate", "rad/s", 0.0, 20.0),
    ParamSpec("turn_interval", 1.0, "wander: time between draws", "s", 0.0, 1e4, low_open=True),
    ParamSpec("speed_change", 0.0, "wander: the speed drawn within +-this fraction of speed", "", 0.0, 1.0),
    ParamSpec("stop_probability", 0.0, "wander: chance of a stop at each draw (stop and go)", "", 0.0, 1.0),
    ParamSpec("stop_time", 0.0, "wander: how long a stop lasts", "s", 0.0, 1e4),
    ParamSpec("roam_radius", 0.0, "wander: beyond this from its start it turns back (0: unbounded)", "m", 0.0, 1e6),
    ParamSpec("react", "none", "social: it avoids the robot and the other obstacles by a social force (Helbing"
              " & Molnar 1995)", choices=REACTIONS),
    ParamSpec("attention", 1.0, "social: weight of the robot in its social force (0: it does not see it)", "",
              0.0, 1.0),
    ParamSpec("social_strength", 2.1, "social: Helbing's A, the push at contact", "m/s²", 0.0, 1000.0),
    ParamSpec("social_range", 0.3, "social: Helbing's B, the push's decay length", "m", 0.0, 100.0, low_open=True),
    ParamSpec("relaxation_time", 0.5, "social: time to regain its desired velocity", "s", 0.0, 100.0,
              low_open=True),
    ParamSpec("anisotropy", 0.5, "social: weight of what is behind it against what is ahead (1: all alike)", "",
              0.0, 1.0),
)
_MOTION_FIELDS = {  # the fields that belong to one motion kind or to the reaction
    "waypoints": ("loop", "pause"),
    "wander": ("max_yaw_rate", "turn_interval", "speed_change", "stop_probability", "stop_time", "roam_radius"),
    "social": ("attention", "social_strength", "social_range", "relaxation_time", "anisotropy"),
}
_VARIATION = (
    ParamSpec("obstacle_position", 0.0, "each obstacle's start moves by up to this in x and in y, per seed", "m",
              0.0, 100.0),
    ParamSpec("obstacle_timing", 0.0, "each obstacle moving straight starts up to this much earlier or later"
              " along its path, per seed", "s", 0.0, 1000.0),
    ParamSpec("obstacle_speed", 0.0, "each moving obstacle's speed changes by up to this fraction, per seed", "",
              0.0, 0.9),
    ParamSpec("target_position", 0.0, "the target's start moves by up to this in x and in y, per seed", "m",
              0.0, 100.0),
)
_COMMAND = (
    ParamSpec("t", 0.0, "time from which the command holds", "s", 0.0, 86400.0),
    ParamSpec("v", 0.0, "forward speed reference", "m/s", -5.0, 5.0),
    ParamSpec("w", 0.0, "yaw-rate reference", "rad/s", -10.0, 10.0),
)


def _section(specs: tuple[ParamSpec, ...], raw: Any, where: str, required: tuple[str, ...] = ()) -> dict[str, Any]:
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise ConfigError(f"invalid field '{where}': must be a mapping, got {type(raw).__name__}")
    known = {s.name: s for s in specs}
    for key in raw:
        if key not in known:
            path = f"{where}.{key}" if where else str(key)
            raise ConfigError(f"unknown field '{path}': known fields are {', '.join(known)}")
    for key in required:
        if key not in raw:
            raise ConfigError(f"missing field '{where}.{key}': {known[key].describe()}")
    out = {}
    for s in specs:
        path = f"{where}.{s.name}" if where else s.name
        value = raw.get(s.name, s.default)
        if s.name in ("heading", "yaw", "pitch"):
            value = parse_angle(value, path)
        named = ParamSpec(**{**s.__dict__, "name": path})
        checked = named.validate(value)
        if s.name == "position" and len(checked) != 2:
            raise ConfigError(f"invalid field '{path}' = {value!r}: must be [x, y] in m")
        if s.name == "position" and any(abs(c) > _BIG for c in checked):
            raise ConfigError(f"invalid field '{path}' = {value!r}: coordinates must be within +-{_BIG:g} m")
        out[s.name] = checked
    return out


def _planner_section(raw: Any) -> tuple[tuple[str, Any], ...]:
    """The `planner` field: parameter names and plain values (their ranges are the planner's to check)."""
    if raw is None:
        return ()
    if not isinstance(raw, dict):
        raise ConfigError("invalid field 'planner': must be a mapping of planner parameters to values")
    for key, value in raw.items():
        if not isinstance(key, str) or not _NAME_RE.match(key):
            raise ConfigError(f"invalid field 'planner': {key!r} is not a parameter name")
        if not isinstance(value, (bool, int, float, str)):
            raise ConfigError(f"invalid field 'planner.{key}' = {value!r}: must be a number, a boolean or a string")
    return tuple(raw.items())


def _waypoints(raw: Any, where: str) -> tuple[tuple[float, float], ...]:
    if not isinstance(raw, (list, tuple)) or not raw:
        raise ConfigError(f"invalid field '{where}' = {raw!r}: must be a non-empty list of [x, y] in m")
    spec = ParamSpec("position", [0.0, 0.0], "", "m")
    out = []
    for k, point in enumerate(raw):
        path = f"{where}[{k}]"
        checked = ParamSpec(**{**spec.__dict__, "name": path}).validate(point)
        if len(checked) != 2 or any(abs(c) > _BIG for c in checked):
            raise ConfigError(f"invalid field '{path}' = {point!r}: must be [x, y] in m, within +-{_BIG:g} m")
        out.append((checked[0], checked[1]))
    return tuple(out)


def _obstacle(raw: Any, k: int) -> ObstacleSpec:
    """One entry of `obstacles`: a field of another motion kind than the entry's is refused by name."""
    where = f"obstacles[{k}]"
    entry = dict(raw) if isinstance(raw, dict) else raw
    waypoints_raw = entry.pop("waypoints", None) if isinstance(entry, dict) else None
    ob = _section(_OBSTACLE, entry, where, required=("position", "radius"))
    given = set(entry) if isinstance(entry, dict) else set()
    kind = ob["motion"]
    own = _MOTION_FIELDS.get(kind, ()) + (_MOTION_FIELDS["social"] if ob["react"] == "social" else ())
    for field_name in sorted(given):
        if any(field_name in names for names in _MOTION_FIELDS.values()) and field_name not in own:
            owner = next(key for key, names in _MOTION_FIELDS.items() if field_name in names)
            needs = "react: social" if owner == "social" else f"motion: {owner}"
            raise ConfigError(f"invalid field '{where}.{field_name}': only for {needs} (this obstacle has motion:"
                              f" {kind}, react: {ob['react']})")
    if (waypoints_raw is not None) != (kind == "waypoints"):
        raise ConfigError(f"invalid field '{where}.waypoints': motion: waypoints needs a list of waypoints, and"
                          f" only it takes one (this obstacle has motion: {kind})")
    if kind != "straight" and ob["speed"] <= 0.0:
        raise ConfigError(f"invalid field '{where}.speed' = {ob['speed']:g}: motion: {kind} needs a speed above 0")
    motion = None
    if kind != "straight":
        motion = MotionSpec(
            kind, ob["speed"], ob["heading"], _waypoints(waypoints_raw, f"{where}.waypoints") if waypoints_raw
            is not None else (), ob["loop"], ob["pause"], ob["max_yaw_rate"], ob["turn_interval"],
            ob["speed_change"], ob["stop_probability"], ob["stop_time"], ob["roam_radius"])
    reaction = None
    if ob["react"] == "social":
        reaction = ReactionSpec(ob["attention"], ob["social_strength"], ob["social_range"], ob["relaxation_time"],
                                ob["anisotropy"])
    straight = kind == "straight"
    return ObstacleSpec(
        ob["id"] if "id" in given else k + 1, ob["position"][0], ob["position"][1],
        ob["speed"] * math.cos(ob["heading"]) if straight else 0.0,
        ob["speed"] * math.sin(ob["heading"]) if straight else 0.0, ob["radius"], motion, reaction,
    )


def parse_scenario(raw: Any, name: str = "scenario", source: str = "") -> Scenario:
    if not isinstance(raw, dict):
        raise ConfigError(f"scenario {source or name}: must be a mapping of fields")
    raw = dict(raw)
    name = str(raw.pop("name", name))
    if not _NAME_RE.match(name):
        # The name becomes a directory under the runner's --out: no separators, no climbing out of it.
        raise ConfigError(f"invalid field 'name' = {name!r}: must be letters, digits, '_', '-' and '.', not"
                          " starting with '.'")
    description = str(raw.pop("description", ""))
    robot_raw = raw.pop("robot", None)
    target_raw = raw.pop("target", None)
    obstacles_raw = raw.pop("obstacles", None) or []
    commands_raw = raw.pop("commands", None) or []
    variation = Variation(**_section(_VARIATION, raw.pop("variation", None), "variation"))
    planner = _planner_section(raw.pop("planner", None))
    top = _section(_TOP, raw, "")
    robot = _section(_ROBOT, robot_raw, "robot")
    target = None
    if target_raw is not None:
        t = _section(_TARGET, target_raw, "target", required=("position",))
        target = TargetSpec(
            t["position"][0], t["position"][1], t["heading"], t["speed"],
            t["max_yaw_rate"], t["turn_interval"], t["capture_radius"],
        )
    if not isinstance(obstacles_raw, list):
        raise ConfigError("invalid field 'obstacles': must be a list of obstacles")
    obstacles = [_obstacle(o, k) for k, o in enumerate(obstacles_raw)]
    ids = [o.id for o in obstacles]
    if len(set(ids)) != len(ids):
        raise ConfigError(f"invalid field 'obstacles': ids must be unique, got {ids}")
    if not isinstance(commands_raw, list):
        raise ConfigError("invalid field 'commands': must be a list of {t, v, w}")
    commands = []
    for k, c in enumerate(commands_raw):
        cm = _section(_COMMAND, c, f"commands[{k}]", required=("t",))
        if commands and cm["t"] <= commands[-1].t:
            raise ConfigError(f"invalid field 'commands[{k}].t' = {cm['t']}: times must increase")
        commands.append(CommandStep(cm["t"], cm["v"], cm["w"]))
    if top["end_on_target"] and target is None:
        raise ConfigError("invalid field 'end_on_target' = True: the scenario has no target")
    if variation.any and not (target is not None or obstacles):
        raise ConfigError("invalid field 'variation': the scenario has no target and no obstacles to vary")
    scenario = Scenario(
        name=name, description=description, duration=top["duration"], seed=top["seed"],
        start_x=robot["x"], start_y=robot["y"], start_yaw=robot["yaw"], start_pitch=robot["pitch"],
        target=target, obstacles=tuple(obstacles), commands=tuple(commands),
        end_on_target=top["end_on_target"], variation=variation, planner=planner, perception=top["perception"],
        source=source,
    )
    if (problem := layout_problem(scenario)) is not None:
        raise ConfigError(problem)
    return scenario


def layout_problem(scenario: Scenario) -> str | None:
    """What makes the layout at t = 0 impossible, or None: a robot that starts inside an obstacle has
    collided already, a target inside one is never reached."""
    target = scenario.target
    points = [("robot", scenario.start_x, scenario.start_y)] + (
        [("target.position", target.x, target.y)] if target else [])
    for o in scenario.obstacles:
        for what, x, y in points:
            if math.hypot(x - o.x, y - o.y) < o.radius:
                return (f"invalid field '{what}' = [{x:g}, {y:g}]: inside obstacle {o.id} (centre"
                        f" [{o.x:g}, {o.y:g}], radius {o.radius:g} m) at t = 0")
    return None


VARIATION_ATTEMPTS = 100  # draws tried for a seed before its layout is refused


def _varied(o: ObstacleSpec, dx: float, dy: float, shift: float, scale: float) -> ObstacleSpec:
    """An obstacle moved by (dx, dy) [m] with its route, `shift` [s] along a straight path, its speed scaled."""
    motion = o.motion
    if motion is not None:
        motion = replace(motion, speed=motion.speed * scale,
                         waypoints=tuple((wx + dx, wy + dy) for wx, wy in motion.waypoints))
    return replace(o, x=o.x + dx + o.vx * shift, y=o.y + dy + o.vy * shift, vx=o.vx * scale, vy=o.vy * scale,
                   motion=motion)


def run_perception(scenario: Scenario, perception: str | None) -> str:
    """What the planner's obstacles come from in a run: the caller's choice, else the scenario's; a run
    without a planner has none to perceive ("truth": nothing is tracked)."""
    if scenario.target is None:
        return "truth"
    return perception or scenario.perception


def vary(scenario: Scenario, seed: int) -> Scenario:
    """The layout of `seed`: the scenario with its variation drawn (itself when it has none).

    The draws come from a stream of their own (the target's turns use the seed too); a draw that puts the
    robot or the target inside an obstacle is drawn again, deterministically."""
    v = scenario.variation
    if not v.any:
        return scenario
    rng = np.random.default_rng([seed, 0x7661])
    for _ in range(VARIATION_ATTEMPTS):
        obstacles = []
        for o in scenario.obstacles:
            dx, dy = rng.uniform(-v.obstacle_position, v.obstacle_position, 2)
            shift = rng.uniform(-v.obstacle_timing, v.obstacle_timing)
            scale = 1.0 + rng.uniform(-v.obstacle_speed, v.obstacle_speed)
            obstacles.append(_varied(o, dx, dy, shift, scale))
        target = scenario.target
        if target is not None:
            dx, dy = rng.uniform(-v.target_position, v.target_position, 2)
            target = replace(target, x=target.x + dx, y=target.y + dy)
        varied = replace(scenario, obstacles=tuple(obstacles), target=target, variation=Variation())
        if layout_problem(varied) is None:
            return varied
    raise ConfigError(f"scenario {scenario.name}: no layout for seed {seed} in {VARIATION_ATTEMPTS} draws keeps"
                      " the robot and the target out of the obstacles; reduce 'variation'")


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file; every problem is a ConfigError naming the file and field."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except OSError as e:
        raise ConfigError(f"scenario file {path}: cannot be read ({e.strerror})") from None
    except yaml.YAMLError as e:
        raise ConfigError(f"scenario file {path}: not valid YAML ({e})") from None
    try:
        return parse_scenario(raw, name=path.stem, source=str(path))
    except ConfigError as e:
        raise ConfigError(f"scenario file {path}: {e}") from None


@kernel
def command_profile_at(times, speeds, yaw_rates, t):
    """(v, w) of a command profile at time t: the last step at or before t (zero before the first)."""
    v = 0.0
    w = 0.0
    for k in range(times.shape[0]):
        if t + 1e-12 >= times[k]:
            v = speeds[k]
            w = yaw_rates[k]
        else:
            break
    return v, w


def command_profile(scenario: Scenario) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The scenario's command steps as arrays (t [s], v [m/s], w [rad/s]) for command_profile_at."""
    steps = scenario.commands
    return (np.array([c.t for c in steps], dtype=float), np.array([c.v for c in steps], dtype=float),
            np.array([c.w for c in steps], dtype=float))


def command_at(scenario: Scenario, t: float) -> tuple[float, float]:
    """The (v, w) the scenario's command profile asks for at time t (zero before its first step)."""
    return command_profile_at(*command_profile(scenario), float(t))
