"""
The parameter machinery both nodes share: specs with type, unit, range, choices and reasons.

No rclpy here (``vibrissa_ros.ros.params`` turns a spec into a ROS ParameterDescriptor and hooks
the validation into the node). A spec's default fixes its type; :meth:`ParameterSpec.check`
raises :class:`~vibrissa_ros.core.errors.ParameterError` naming the parameter, its value and what
is allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, Iterable, Mapping, Optional, Tuple

from ..core.errors import ParameterError


@dataclass(frozen=True)
class ParameterSpec:
    """
    One node parameter: its default (which fixes its type), unit, description and range.

    The parameters are the dataclass's fields, kept as attributes of the same names.

    Parameters
    ----------
    name : str
        The parameter's name (dotted, e.g. ``whisker.length``).
    default : bool, int, float or str
        The default value; its type is the parameter's type.
    description : str
        What the parameter is, for its ROS ParameterDescriptor and the messages.
    unit : str, optional
        The unit (SI, e.g. ``m``, ``1/m``), empty when it has none.
    read_only : bool, optional
        The parameter cannot change at runtime (the descriptor's ``read_only``).
    minimum, maximum : float or None, optional
        The bounds of a number, inclusive; None: unbounded.
    exclusive_minimum : bool, optional
        The number must be strictly greater than ``minimum``.
    choices : tuple of str, optional
        The allowed strings; empty: any.
    nonempty : bool, optional
        A string must not be blank.
    resets : bool, optional
        A runtime change rebuilds the whisker (free state).

    """

    name: str
    default: Any
    description: str
    unit: str = ""
    read_only: bool = False
    minimum: Optional[float] = None
    maximum: Optional[float] = None
    exclusive_minimum: bool = False
    choices: Tuple[str, ...] = ()
    nonempty: bool = False
    resets: bool = True

    @property
    def kind(self) -> type:
        """bool, int, float or str: the type of the default."""
        return type(self.default)

    def allowed(self) -> str:
        """Return what values are allowed, in words ('> 0', 'in [2, 10000]', "'a', 'b'")."""
        if self.choices:
            return ", ".join(repr(c) for c in self.choices)
        lo, hi = self.minimum, self.maximum
        if lo is not None and hi is not None:
            if self.exclusive_minimum:
                return f"> {lo!r} and <= {hi!r}"
            return f"in [{lo!r}, {hi!r}]"
        if lo is not None:
            return f"{'>' if self.exclusive_minimum else '>='} {lo!r}"
        if hi is not None:
            return f"<= {hi!r}"
        return "any finite number" if self.kind in (int, float) else f"any {self.kind.__name__}"

    def problem(self, value: Any) -> Optional[str]:
        """Return what is wrong with ``value`` ('must be finite', ...), or None if allowed."""
        if self.kind is bool:
            return None if isinstance(value, bool) else "must be true or false"
        if self.kind is str:
            if not isinstance(value, str):
                return "must be a string"
            if self.nonempty and not value.strip():
                return "must be a non-empty frame id"
            if self.choices and value not in self.choices:
                return f"is not allowed; allowed: {self.allowed()}"
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return "must be a number"
        if self.kind is int and not isinstance(value, int):
            return f"must be an integer {self.allowed()}"
        if not math.isfinite(value):
            return "must be finite"
        lo, hi = self.minimum, self.maximum
        low = lo is not None and (value <= lo if self.exclusive_minimum else value < lo)
        if low or (hi is not None and value > hi):
            return f"is not allowed: it must be {'an integer ' if self.kind is int else ''}" \
                   f"{self.allowed()}"
        return None

    def check(self, value: Any) -> Any:
        """Return the value in the spec's type; raise :class:`ParameterError` with the reason."""
        problem = self.problem(value)
        if problem is not None:
            unit = f" {self.unit}" if self.unit and problem.startswith("is not") else ""
            raise ParameterError(f"{self.name} = {value!r}{unit} {problem}")
        return self.kind(value) if self.kind in (int, float) else value


def positive(name: str, default: float, description: str, unit: str, **kw) -> ParameterSpec:
    """Return a number that must be > 0."""
    return ParameterSpec(name, default, description, unit, minimum=0.0, exclusive_minimum=True,
                         **kw)


def nonnegative(name: str, default: float, description: str, unit: str = "",
                **kw) -> ParameterSpec:
    """Return a number that must be >= 0."""
    return ParameterSpec(name, default, description, unit, minimum=0.0, **kw)


def validate(specs: Iterable[ParameterSpec], values: Mapping[str, Any]) -> Dict[str, Any]:
    """
    Return every spec's value (its default where ``values`` has none), checked.

    The first bad one raises :class:`ParameterError`.
    """
    return {spec.name: spec.check(values.get(spec.name, spec.default)) for spec in specs}
