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
class ObstacleSpec:
    """A circular obstacle: position [m] (at t = 0 in a scenario, now in World.obstacles()), velocity [m/s]."""

    id: int
    x: float
    y: float
    vx: float
    vy: float
    radius: float


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
    obstacle_timing: float = 0.0  # [s] a moving obstacle starts this much earlier or later along its path
    obstacle_speed: float = 0.0  # fraction of a moving obstacle's speed
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
    source: str = field(default="", compare=False)


_BIG = 1e6
_TOP = (
    ParamSpec("duration", 60.0, "time limit of the run", "s", 0.0, 86400.0, low_open=True),
    ParamSpec("seed", 0, "seed of the target's random turns (a node's seed parameter overrides it)", "", 0, 2**31 - 1),
    ParamSpec("end_on_target", False, "end the run when the target is reached"),
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
    ParamSpec("speed", 0.0, "constant speed", "m/s", 0.0, 100.0),
    ParamSpec("heading", 0.0, "direction of motion", "rad", -2 * math.pi, 2 * math.pi),
)
_VARIATION = (
    ParamSpec("obstacle_position", 0.0, "each obstacle's start moves by up to this in x and in y, per seed", "m",
              0.0, 100.0),
    ParamSpec("obstacle_timing", 0.0, "each moving obstacle starts up to this much earlier or later along its"
              " path, per seed", "s", 0.0, 1000.0),
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
    obstacles = []
    for k, o in enumerate(obstacles_raw):
        ob = _section(_OBSTACLE, o, f"obstacles[{k}]", required=("position", "radius"))
        if "id" not in (o or {}):
            ob["id"] = k + 1
        obstacles.append(
            ObstacleSpec(
                ob["id"], ob["position"][0], ob["position"][1],
                ob["speed"] * math.cos(ob["heading"]), ob["speed"] * math.sin(ob["heading"]), ob["radius"],
            )
        )
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
        end_on_target=top["end_on_target"], variation=variation, planner=planner, source=source,
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
            obstacles.append(ObstacleSpec(o.id, o.x + dx + o.vx * shift, o.y + dy + o.vy * shift, o.vx * scale,
                                          o.vy * scale, o.radius))
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
