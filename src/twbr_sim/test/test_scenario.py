import math
from pathlib import Path

import pytest
import yaml

from twbr_common.params import ConfigError
from twbr_sim.scenario import command_at, load_scenario, parse_scenario

CONFIG = Path(__file__).resolve().parents[3] / "config" / "scenarios"
SCENARIOS = sorted(p.stem for p in CONFIG.glob("*.yaml"))


def test_the_papers_four_scenarios_ship():
    assert {"dynamic_obstacles", "dynamic_target", "static", "step"} <= set(SCENARIOS)


@pytest.mark.parametrize("name", SCENARIOS)
def test_shipped_scenarios_load(name):
    sc = load_scenario(CONFIG / f"{name}.yaml")
    assert sc.name == name and sc.duration > 0


def test_scenarios_carry_the_papers_numbers():
    static = load_scenario(CONFIG / "static.yaml")
    assert (static.target.x, static.target.y, static.target.speed) == (10.0, 10.0, 0.0)
    assert len(static.obstacles) == 3 and all(o.vx == o.vy == 0 for o in static.obstacles)
    dyn = load_scenario(CONFIG / "dynamic_obstacles.yaml")
    assert (dyn.target.x, dyn.target.y, dyn.target.speed, dyn.target.max_yaw_rate) == (10.0, 15.0, 0.25, 1.0)
    o1, o2 = dyn.obstacles
    assert o1.radius == 1.5 and math.atan2(o1.vy, o1.vx) == pytest.approx(3 * math.pi / 4)
    assert math.hypot(o1.vx, o1.vy) == pytest.approx(0.28)
    assert o2.radius == 2.0 and math.atan2(o2.vy, o2.vx) == pytest.approx(-math.pi / 2)
    assert math.hypot(o2.vx, o2.vy) == pytest.approx(0.1)
    step = load_scenario(CONFIG / "step.yaml")
    assert command_at(step, 0.5) == (0.0, 0.0) and command_at(step, 1.0) == (0.1, 0.0)


def test_static_obstacles_block_the_straight_line():
    """Our choice of positions must put every obstacle in the robot's way (within its footprint)."""
    for name, (tx, ty) in [("static", (10, 10)), ("dynamic_target", (10, 15))]:
        sc = load_scenario(CONFIG / f"{name}.yaml")
        for o in sc.obstacles:
            off_line = abs(ty * o.x - tx * o.y) / math.hypot(tx, ty)
            assert off_line < o.radius + 0.3, (name, o.id)


BASE = {"duration": 10.0, "target": {"position": [1.0, 2.0]}, "obstacles": [{"position": [0, 3], "radius": 1.0}]}


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["obstacles"][0].update(radius=-2.0), "'obstacles[0].radius' = -2.0: must be (0, 1000] m"),
        (lambda d: d["obstacles"][0].pop("position"), "missing field 'obstacles[0].position'"),
        (lambda d: d["obstacles"][0].update(position=[1.0]), "'obstacles[0].position'"),
        (lambda d: d["obstacles"][0].update(heading="3tau/4"), "'obstacles[0].heading' = '3tau/4'"),
        (lambda d: d["obstacles"][0].update(colour="red"), "unknown field 'obstacles[0].colour'"),
        (lambda d: d["target"].update(speed=-1), "'target.speed' = -1: must be [0, 10] m/s"),
        (lambda d: d["target"].update(capture_radius=0), "'target.capture_radius' = 0"),
        (lambda d: d.update(duration=0), "'duration' = 0: must be (0, 86400] s"),
        (lambda d: d.update(durration=5), "unknown field 'durration'"),
        (lambda d: d.update(seed=-3), "'seed' = -3"),
        (lambda d: d.update(obstacles=[{"id": 1, "position": [0, 0], "radius": 1}] * 2), "ids must be unique"),
        (lambda d: d.update(commands=[{"t": 1.0}, {"t": 0.5}]), "'commands[1].t' = 0.5: times must increase"),
        (lambda d: d.update(commands=[{"t": 1.0, "v": 9.0}]), "'commands[0].v' = 9.0: must be [-5, 5] m/s"),
        (lambda d: (d.pop("target"), d.update(end_on_target=True)), "'end_on_target'"),
        (lambda d: d.update(robot=[0, 0]), "'robot': must be a mapping"),
        # Before: a ZeroDivisionError traceback, a robot or a target inside an obstacle accepted, and a name
        # that wrote the run outside --out.
        (lambda d: d["obstacles"][0].update(heading="3pi/0"), "'obstacles[0].heading' = '3pi/0': divides by zero"),
        (lambda d: d.update(name="../../etc/cron.d/x"), "invalid field 'name' = '../../etc/cron.d/x'"),
        (lambda d: d.update(name=".hidden"), "invalid field 'name'"),
        (lambda d: d.update(obstacles=[{"id": 4, "position": [0.1, 0.2], "radius": 0.5}]),
         "'robot' = [0, 0]: inside obstacle 4"),
        (lambda d: d.update(obstacles=[{"id": 5, "position": d["target"]["position"], "radius": 0.3}]),
         "'target.position'"),
    ],
)
def test_malformed_scenarios_are_refused_naming_the_field(edit, message):
    import copy

    d = copy.deepcopy(BASE)
    edit(d)
    with pytest.raises(ConfigError) as e:
        parse_scenario(d)
    assert message in str(e.value)


def test_angles_accept_multiples_of_pi():
    d = {"duration": 1.0, "obstacles": [{"position": [5, 0], "radius": 1, "speed": 1, "heading": h}
                                        for h in ("3pi/4", "-pi/2", "pi", "0.5")]}
    sc = parse_scenario(d)
    headings = [math.atan2(o.vy, o.vx) for o in sc.obstacles]
    assert headings == pytest.approx([3 * math.pi / 4, -math.pi / 2, math.pi, 0.5])


def test_unreadable_and_non_yaml_files_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="cannot be read"):
        load_scenario(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("target: [unclosed\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_scenario(bad)
    listy = tmp_path / "list.yaml"
    listy.write_text(yaml.safe_dump([1, 2]))
    with pytest.raises(ConfigError, match="must be a mapping"):
        load_scenario(listy)
