import pytest

from twbr_common.params import ConfigError, ParamSpec, markdown_table, validate_all

RADIUS = ParamSpec("wheel_radius", 0.1, "wheel radius", "m", 0.0, 5.0, low_open=True)
MODE = ParamSpec("mode", "lockstep", "stepping mode", choices=("lockstep", "realtime"))
COUNT = ParamSpec("count", 3, "how many", "", 1, 10)
FLAG = ParamSpec("flag", True, "a switch")


@pytest.mark.parametrize(
    ("spec", "value", "message"),
    [
        (RADIUS, -1.0, "invalid parameter 'wheel_radius' = -1.0: must be (0, 5] m"),
        (RADIUS, 0.0, "invalid parameter 'wheel_radius' = 0.0: must be (0, 5] m"),
        (RADIUS, 5.5, "must be (0, 5] m"),
        (RADIUS, float("nan"), "not finite"),
        (RADIUS, "big", "not a number"),
        (RADIUS, True, "not a number"),
        (MODE, "fast", "must be one of 'lockstep', 'realtime'"),
        (COUNT, 2.5, "not an integer"),
        (COUNT, 0, "must be [1, 10]"),
        (FLAG, 1, "not a boolean"),
    ],
)
def test_bad_values_are_refused_naming_parameter_and_range(spec, value, message):
    with pytest.raises(ConfigError) as e:
        spec.validate(value)
    assert message in str(e.value)
    assert f"'{spec.name}'" in str(e.value)


def test_good_values_pass_and_convert():
    assert RADIUS.validate(1) == 1.0 and isinstance(RADIUS.validate(1), float)
    assert COUNT.validate(4.0) == 4 and isinstance(COUNT.validate(4.0), int)
    assert MODE.validate("realtime") == "realtime"


def test_validate_all_fills_defaults_and_refuses_unknown_names():
    assert validate_all([RADIUS, MODE], {"mode": "realtime"}) == {"wheel_radius": 0.1, "mode": "realtime"}
    with pytest.raises(ConfigError, match="unknown parameter 'wheel_raduis'"):
        validate_all([RADIUS], {"wheel_raduis": 0.2})


def test_markdown_table_lists_every_spec():
    table = markdown_table([RADIUS, MODE])
    assert "| `wheel_radius` | 0.1 | m | (0, 5] m |" in table
    assert "`mode`" in table
