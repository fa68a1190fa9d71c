"""The ROS parameters of the swarm's nodes and programs: each one's name, default and meaning.

A node declares its parameters from these specs (``SwarmNode.declare``), a
program's ``--help`` lists them without starting a node (:func:`help_text`),
and a value set while the node runs (``ros2 param set``) is checked by the
same rule as a value given at the start.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from string import hexdigits

from ...core.errors import SwazureError


class ParameterError(SwazureError):
    """A node parameter with a value the node cannot run with."""


#: A parameter's value, as ROS 2 parameters hold them here.
Value = bool | int | float | str
#: Why a value is refused (None: accepted).
Rule = Callable[[Value], str | None]

#: Seconds a period or timeout parameter may be, at most (a day): longer is a typo, and
#: timers of non-finite periods do not exist.
MAX_SECONDS = 86400.0
#: ROS 2's names of the parameter types, by the Python type of a default.
TYPE_NAMES = {bool: "bool", int: "int", float: "double", str: "string"}


def any_value(value: Value) -> str | None:
    """Every value of the parameter's type is accepted."""
    return None


def seconds(allow_zero: bool = False) -> Rule:
    """The rule of a period or timeout: seconds > 0 (or 0 if allowed), below MAX_SECONDS."""
    kind = "0 or a positive" if allow_zero else "a positive"

    def rule(value: Value) -> str | None:
        if isinstance(value, float) and ((0 < value < MAX_SECONDS) or (allow_zero and value == 0)):
            return None
        return f"must be {kind} number of seconds below {MAX_SECONDS:g}, got {value!r}"

    return rule


def at_least(lowest: int) -> Rule:
    """The rule of a whole number no smaller than ``lowest``."""

    def rule(value: Value) -> str | None:
        if isinstance(value, int) and not isinstance(value, bool) and value >= lowest:
            return None
        return f"must be a whole number >= {lowest}, got {value!r}"

    return rule


def hex_digits(digits: int) -> Rule:
    """The rule of a string of ``digits`` hexadecimal digits, or '' (none given)."""

    def rule(value: Value) -> str | None:
        if isinstance(value, str) and (
            value == "" or (len(value) == digits and all(c in hexdigits for c in value))
        ):
            return None
        return f"must be {digits} hexadecimal digits (or '' for none), got {value!r}"

    return rule


@dataclass(frozen=True)
class ParameterSpec:
    """One ROS parameter: its name, its default (which sets its type) and what it means.

    ``description`` says the unit; ``rule`` says why a value is refused.
    """

    name: str
    default: Value
    description: str
    rule: Rule = field(default=any_value, compare=False)

    @property
    def option(self) -> str:
        """The program argument that gives it at start: ``fls_id`` is ``--fls-id``."""
        return "--" + self.name.replace("_", "-").replace(".", "-")

    @property
    def type_name(self) -> str:
        """The parameter's ROS 2 type: bool, int, double or string."""
        return TYPE_NAMES[type(self.default)]

    def refuses(self, value: Value) -> str | None:
        """Why ``value`` is refused, or None."""
        return self.rule(value)


def help_text(
    usage: str,
    about: str,
    specs: Sequence[ParameterSpec],
    arguments: Sequence[ParameterSpec] = (),
) -> str:
    """A program's ``--help``: usage, what it does, its startup ``arguments`` and every
    parameter, each with its default."""
    lines = [f"usage: {usage}", "", about.strip()]
    for title, listed, name in (
        ("arguments, before --ros-args (--NAME VALUE; default):", arguments, _option_of),
        ("parameters (-p NAME:=VALUE; default):", specs, _name_of),
    ):
        if not listed:
            continue
        lines += ["", title]
        for spec in listed:
            default = repr(spec.default) if isinstance(spec.default, str) else str(spec.default)
            lines.append(f"  {name(spec)} ({spec.type_name}, {default})")
            lines.append(f"      {spec.description}")
    return "\n".join(lines)


def _option_of(spec: ParameterSpec) -> str:
    return spec.option


def _name_of(spec: ParameterSpec) -> str:
    return spec.name
