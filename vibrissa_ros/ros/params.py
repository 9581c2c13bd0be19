"""
The shared parameter machinery in ROS: descriptors with ranges, validation with reasons.

Both nodes declare their :class:`~vibrissa_ros.node.parameters.ParameterSpec` tuple through
:class:`NodeParameters`: every parameter gets a description (with its unit), its range and
read-only flag as a ROS descriptor; the whole set is validated by the node's ``build`` function at
start-up (an invalid file raises :class:`ParameterError`) and on every runtime change (a rejected
change says why); an accepted change is handed to the node's ``apply`` callback.
"""

from __future__ import annotations

from typing import Any, Callable, Dict, Generic, Iterable, Mapping, Optional, Sequence, TypeVar

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.exceptions import InvalidParameterValueException
from rclpy.node import Node

from ..core.errors import ParameterError
from ..node.parameters import ParameterSpec

Config = TypeVar("Config")
_INT64 = (-(2**63), 2**63 - 1)


def descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    """Return the ROS descriptor of a spec: description [unit], allowed, range, read-only."""
    text = spec.description + (f" [{spec.unit}]" if spec.unit else "")
    if spec.choices or spec.exclusive_minimum:
        text += f"; allowed: {spec.allowed()}"
    desc = ParameterDescriptor(description=text, read_only=spec.read_only)
    if spec.minimum is None and spec.maximum is None:
        return desc
    if spec.kind is float:
        lo = -float("inf") if spec.minimum is None else float(spec.minimum)
        hi = float("inf") if spec.maximum is None else float(spec.maximum)
        desc.floating_point_range = [FloatingPointRange(from_value=lo, to_value=hi, step=0.0)]
    elif spec.kind is int:
        lo = _INT64[0] if spec.minimum is None else int(spec.minimum)
        hi = _INT64[1] if spec.maximum is None else int(spec.maximum)
        desc.integer_range = [IntegerRange(from_value=lo, to_value=hi, step=1)]
    return desc


class NodeParameters(Generic[Config]):
    """
    Declares a node's parameters and keeps its validated configuration up to date.

    ``build(values)`` validates a full set of values and returns the node's configuration (or
    raises :class:`ParameterError`); ``apply(config, names)`` takes an accepted runtime change.
    """

    def __init__(self, node: Node, specs: Sequence[ParameterSpec],
                 build: Callable[[Mapping[str, Any]], Config],
                 apply: Optional[Callable[[Config, Iterable[str]], None]] = None):
        self._node = node
        self.specs = {spec.name: spec for spec in specs}
        self._build = build
        self._apply = apply
        for spec in specs:
            self._declare(spec)
        self.config: Config = build(self.values())  # raises: an invalid start-up configuration
        node.add_on_set_parameters_callback(self._validate)
        node.add_post_set_parameters_callback(self._accepted)

    def _declare(self, spec: ParameterSpec) -> None:
        try:
            self._node.declare_parameter(spec.name, spec.default, descriptor(spec))
        except InvalidParameterValueException:
            # out of the descriptor's range: say it in the spec's words, with the value given
            override = getattr(self._node, "_parameter_overrides", {}).get(spec.name)
            if override is not None:
                spec.check(override.value)
            raise

    def values(self, overrides: Optional[Mapping[str, Any]] = None) -> Dict[str, Any]:
        """Every parameter's current value, with ``overrides`` applied."""
        values = {name: self._node.get_parameter(name).value for name in self.specs}
        values.update(overrides or {})
        return values

    def _validate(self, params) -> SetParametersResult:
        overrides = {p.name: p.value for p in params if p.name in self.specs}
        try:
            self._build(self.values(overrides))
        except ParameterError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _accepted(self, params) -> None:
        self.config = self._build(self.values())
        if self._apply is not None:
            self._apply(self.config, [p.name for p in params if p.name in self.specs])

    def resets(self, names: Iterable[str]) -> bool:
        """Whether a change of these parameters rebuilds the whisker."""
        return any(self.specs[name].resets for name in names)


__all__ = ["NodeParameters", "descriptor"]
