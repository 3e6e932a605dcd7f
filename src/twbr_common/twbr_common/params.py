"""Parameter specifications: one table per node, shared by the ROS adapter and the headless cores.

Each parameter is declared once, with its default, unit, valid range and description, so the node's
descriptors, the start-up validation, the headless batch runs and docs/parameters.md all say the same thing.
A bad value raises ConfigError with one message naming the parameter and its valid range.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any


class ConfigError(ValueError):
    """A parameter or configuration file that the node must refuse at start-up."""


def env_choice(name: str, choices: tuple[str, ...], default: str) -> str:
    """An environment variable that selects one of `choices` (unset: `default`); anything else is refused."""
    value = os.environ.get(name, default)
    if value not in choices:
        raise ConfigError(f"invalid environment variable {name} = {value!r}: must be one of {', '.join(choices)}")
    return value


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: name, default, unit, description and valid range.

    `low`/`high` bound numbers, and each number of a list (inclusive unless `low_open`/`high_open`);
    `choices` bounds strings; `item` is the type of a list's numbers. A `tunable` parameter may be changed
    while the node runs (SetParameters); the others are read-only, and `fixed_because` says why.
    """

    name: str
    default: Any
    description: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple[str, ...] | None = None
    item: type = float
    tunable: bool = False
    fixed_because: str = "it shapes the node's schedule, topics or buffers, set up at start-up"

    @property
    def kind(self) -> type:
        return type(self.default)

    def range_text(self) -> str:
        """The valid range as a user reads it, e.g. '(0, 2] m'."""
        if self.choices is not None:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        if self.kind is bool:
            return "true or false"
        if self.kind is str:
            return "a string"
        if self.kind is list:
            numbers = "integers" if self.item is int else "numbers"
            if self.low is None and self.high is None:
                return f"a list of {numbers}"
            return f"a list of {numbers} in {replace(self, default=self.item(0)).range_text()}"
        fmt = "d" if self.kind is int else "g"  # an int's bound in full: 2147483647, not 2.14748e+09
        lo = "-inf" if self.low is None else format(self.low, fmt)
        hi = "inf" if self.high is None else format(self.high, fmt)
        left = "(" if (self.low_open or self.low is None) else "["
        right = ")" if (self.high_open or self.high is None) else "]"
        unit = f" {self.unit}" if self.unit else ""
        return f"{left}{lo}, {hi}{right}{unit}"

    def describe(self) -> str:
        unit = f" [{self.unit}]" if self.unit else ""
        when = "changeable at runtime" if self.tunable else f"read-only at runtime: {self.fixed_because}"
        return f"{self.description}{unit}; valid: {self.range_text()}; {when}"

    def _fail(self, value: Any, why: str = "") -> ConfigError:
        extra = f" ({why})" if why else ""
        return ConfigError(
            f"invalid parameter '{self.name}' = {value!r}{extra}: must be {self.range_text()}"
        )

    def validate(self, value: Any) -> Any:
        """Return the value converted to the spec's type, or raise ConfigError."""
        kind = self.kind
        if kind is bool:
            if not isinstance(value, bool):
                raise self._fail(value, "not a boolean")
            return value
        if kind is str:
            if not isinstance(value, str):
                raise self._fail(value, "not a string")
            if self.choices is not None and value not in self.choices:
                raise self._fail(value)
            return value
        if kind is list:
            if not isinstance(value, (list, tuple)):
                raise self._fail(value, "not a list")
            out = []
            for item in value:
                out.append(self._check_number(item, self.item, value))
            return out
        return self._check_number(value, kind, value)

    def _check_number(self, value: Any, kind: type, shown: Any) -> Any:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self._fail(shown, "not a number")
        if kind is int and not float(value).is_integer():
            raise self._fail(shown, "not an integer")
        number = kind(value)
        if not math.isfinite(number):
            raise self._fail(shown, "not finite")
        if self.low is not None and (number < self.low or (self.low_open and number == self.low)):
            raise self._fail(shown)
        if self.high is not None and (
            number > self.high or (self.high_open and number == self.high)
        ):
            raise self._fail(shown)
        return number


def validate_all(specs: Iterable[ParamSpec], values: Mapping[str, Any]) -> dict[str, Any]:
    """Validate `values` (missing ones take their default) and refuse names no spec knows."""
    specs = list(specs)
    known = {s.name for s in specs}
    unknown = sorted(set(values) - known)
    if unknown:
        raise ConfigError(
            f"unknown parameter '{unknown[0]}': known parameters are " + ", ".join(sorted(known))
        )
    return {s.name: s.validate(values.get(s.name, s.default)) for s in specs}


def defaults(specs: Iterable[ParamSpec]) -> dict[str, Any]:
    return {s.name: s.default for s in specs}


def markdown_table(specs: Iterable[ParamSpec]) -> str:
    """A parameter table of docs/parameters.md, generated from the same specs."""
    rows = ["| parameter | default | unit | valid | meaning |", "|---|---|---|---|---|"]
    for s in specs:
        default = str(s.default).lower() if isinstance(s.default, bool) else s.default
        runtime = " (changeable at runtime)" if s.tunable else ""
        rows.append(
            f"| `{s.name}` | {default!s} | {s.unit} | {s.range_text()} | {s.description}{runtime} |"
        )
    return "\n".join(rows)


def default_of(specs: Iterable[ParamSpec], name: str) -> Any:
    """The default of one parameter: the one place a default is written is its spec."""
    for spec in specs:
        if spec.name == name:
            return spec.default
    raise KeyError(f"no parameter {name!r} in these specs")


def tunable(*specs: ParamSpec) -> tuple[ParamSpec, ...]:
    """The same specs, changeable while the node runs."""
    return tuple(replace(s, tunable=True) for s in specs)


def closest_name(name: str, known: Iterable[str], cutoff: float = 0.6) -> str | None:
    """The known name a typo most likely meant, or None when nothing is close (difflib's ratio below
    `cutoff`)."""
    import difflib

    found = difflib.get_close_matches(name, list(known), n=1, cutoff=cutoff)
    return found[0] if found else None
