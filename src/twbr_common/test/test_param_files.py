"""Params files checked the way rcl applies them (pure Python: the e2e tests start the real nodes)."""

from pathlib import Path

import pytest

from twbr_common.param_files import check_overrides, key_matches, node_parameters, parameter_overrides, preflight
from twbr_common.params import ConfigError

DECLARED = ("use_sim_time", "rate", "pitch.kp", "pitch.kd", "velocity.kp")


@pytest.mark.parametrize(("key", "name", "applies"), [
    ("/controller_node", "/controller_node", True),
    ("/controller_node", "/robot1/controller_node", False),  # why the shipped files are keyed /**/...
    ("/**/controller_node", "/robot1/controller_node", True),
    ("/**/controller_node", "/controller_node", True),
    ("/**/controller_node", "/a/b/controller_node", True),
    ("/**", "/a/planner_node", True),
    ("/*/controller_node", "/robot1/controller_node", True),
    ("/*/controller_node", "/controller_node", False),
    ("/robot1/controller_node", "/robot2/controller_node", False),
])
def test_section_keys_match_node_names_as_rcl_does(key, name, applies):
    assert key_matches(key, name) is applies


def _write(tmp_path: Path, text: str) -> str:
    path = tmp_path / "p.yaml"
    path.write_text(text)
    return str(path)


def test_a_file_applies_nested_and_flattened_names(tmp_path):
    path = _write(tmp_path, "/**/controller_node:\n  ros__parameters:\n    rate: 100.0\n    pitch: {kp: 40.0}\n"
                            "other_package_node:\n  ros__parameters: {x: 1}\n")
    assert node_parameters(Path(path), "controller_node", "/robot1") == {"rate": 100.0, "pitch.kp": 40.0}
    check_overrides(["x", "--ros-args", "--params-file", path], "controller_node", "/robot1", DECLARED)


@pytest.mark.parametrize(("text", "args", "message"), [
    ("/**/controller_node:\n  ros__parameters:\n    pitch.kpp: 1.0\n", (),
     "unknown parameter 'pitch.kpp' in params file"),
    ("contoller_node:\n  ros__parameters:\n    rate: 1.0\n", (), "did you mean 'controller_node'?"),
    ("controller_node:\n  ros__parameters:\n    rate: 1.0\n", (), "has no section for /robot1/controller_node"),
    ("/**/controller_node:\n  ros__parameters:\n    rate: 1.0\n", ("-p", "pitch.kpp:=2.0"),
     "unknown parameter 'pitch.kpp' (-p pitch.kpp:=...)"),
])
def test_what_rcl_would_ignore_is_refused_naming_the_closest_name(tmp_path, text, args, message):
    argv = ["x", "--ros-args", "--params-file", _write(tmp_path, text), *args]
    with pytest.raises(ConfigError) as e:
        check_overrides(argv, "controller_node", "/robot1", DECLARED)
    assert message in str(e.value)
    if "kpp" in message:
        assert "did you mean 'pitch.kp'?" in str(e.value)


@pytest.mark.parametrize(("text", "message"), [
    ("controller_node:\n  rate: 1.0\n", "has no ros__parameters"),
    ("controller_node:\n  ros__parameters:\n    rate: [1.0\n", "not valid YAML at line 4"),
    ("- a\n- b\n", "expected sections keyed by node name"),
])
def test_unreadable_files_are_one_line_before_rcl_sees_them(tmp_path, text, message):
    with pytest.raises(ConfigError, match=message.replace("(", r"\(").replace("[", r"\[")):
        preflight(["x", "--ros-args", "--params-file", _write(tmp_path, text)])
    with pytest.raises(ConfigError, match="cannot read params file"):
        preflight(["x", "--ros-args", "--params-file", str(tmp_path / "missing.yaml")])


def test_overrides_for_another_node_are_left_to_it():
    argv = ["x", "--ros-args", "-p", "planner_node:k_o:=3.0", "-p", "rate:=100.0", "--", "--not-ros", "-p"]
    assert parameter_overrides(argv) == [("planner_node", "k_o"), (None, "rate")]
    check_overrides(argv, "controller_node", "/", DECLARED)


@pytest.mark.parametrize("text, args, shown", [
    ('n:\n  ros__parameters:\n    use_sim_time: "yes"\n', [], "'yes'"),
    ("n:\n  ros__parameters:\n    use_sim_time: 1\n", [], "1"),
    ("", ["-p", "use_sim_time:=1"], "1"),
    ("", ["-p", "use_sim_time:=maybe"], "'maybe'"),
    ("", ["-p", "start_type_description_service:=2.5"], "2.5"),
])
def test_rclpys_own_parameters_of_the_wrong_type_are_one_line(tmp_path, text, args, shown):
    """rclpy refuses these inside Node() with a 33-line traceback: preflight names them first."""
    argv = ["node", "--ros-args", *args]
    if text:
        (tmp_path / "p.yaml").write_text(text)
        argv += ["--params-file", str(tmp_path / "p.yaml")]
    with pytest.raises(ConfigError, match=r"invalid parameter '(use_sim_time|start_type_description_service)'"
                                          rf" = {shown}.*must be true or false") as e:
        preflight(argv)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("value", ["true", "false", "True", "yes"])
def test_rclpys_own_parameters_of_the_right_type_pass(value):
    preflight(["node", "--ros-args", "-p", f"use_sim_time:={value}"])
