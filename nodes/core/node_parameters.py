"""A node's declared parameters (rclpy's ``declare_parameter``/``get_parameter``/``set_parameter``) and the
``~/get_parameters`` / ``~/set_parameters`` services that expose them to ``zenroid param``."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from msgs.zenroid_msgs import GetParameters, SetParameters
from nodes.core.params import (
    ParameterDescriptor,
    ParameterError,
    coerce,
    dump_value,
    parse_value,
    type_of_default,
)


class NodeParameters:
    def __init__(self, overrides: dict[str, Any] | None) -> None:
        self._overrides = dict(overrides or {})  # launch, params file, --param: declared or not
        self._values: dict[str, Any] = {}
        self._descriptors: dict[str, ParameterDescriptor] = {}
        self._callbacks: list[Callable[[str, Any], str | None]] = []
        # told ("new" | "changed", names) after a declaration or a set took effect: /parameter_events
        self.listener: Callable[[str, list[str]], None] | None = None

    def declare(self, name: str, default: Any, *, description: str = "", type: type | None = None,
                min_value: float | None = None, max_value: float | None = None,
                choices: list[Any] | tuple[Any, ...] | None = None,
                validator: Callable[[Any], str | None] | None = None, read_only: bool | str = False) -> Any:
        if name in self._descriptors:
            raise ParameterError(f"parameter '{name}' declared twice")
        ptype = type if type is not None else (type_of_default(default) if default is not None else None)
        desc = ParameterDescriptor(name, default, ptype, description, min_value, max_value,
                                   tuple(choices) if choices is not None else None, validator, read_only)
        value = coerce(desc, self._overrides.get(name, default))
        self._descriptors[name] = desc
        self._values[name] = value
        self._tell("new", [name])
        return value

    def get(self, name: str) -> Any:
        if name not in self._values:
            raise ParameterError(f"parameter '{name}' is not declared")
        return self._values[name]

    def has_override(self, name: str) -> bool:
        return name in self._overrides

    def overrides(self) -> dict[str, Any]:
        return dict(self._overrides)

    def set(self, name: str, value: Any) -> Any:
        value = self.check(name, value)
        self._values[name] = value
        self._tell("changed", [name])
        return value

    def set_all(self, values: dict[str, Any]) -> dict[str, Any]:
        """All or nothing: every value is checked (declaration, then the on-set callbacks) before any is
        stored; the first problem raises ParameterError and nothing changes."""
        checked = {name: self.check(name, value) for name, value in values.items()}
        self._values.update(checked)
        self._tell("changed", list(checked))
        return checked

    def _tell(self, kind: str, names: list[str]) -> None:
        if self.listener is not None and names:
            self.listener(kind, names)

    def check(self, name: str, value: Any) -> Any:
        """The value ``set`` would store (coerced), or ParameterError saying why it would be refused."""
        desc = self._descriptors.get(name)
        if desc is None:
            raise ParameterError(f"parameter '{name}' is not declared")
        if desc.read_only:
            why = desc.read_only if isinstance(desc.read_only, str) else "fixed at start-up: restart the node to change it"
            raise ParameterError(f"parameter '{name}' is read-only ({why})")
        value = coerce(desc, value)
        for callback in self._callbacks:
            problem = callback(name, value)
            if problem:
                raise ParameterError(f"parameter '{name}': {problem}")
        return value

    def descriptor(self, name: str) -> ParameterDescriptor | None:
        return self._descriptors.get(name)

    def names(self) -> list[str]:
        """Declared names, in declaration order."""
        return list(self._values)

    def store(self, name: str, value: Any) -> None:
        """Record a value another layer has checked (rclpy's parameters, with their own descriptors and
        callbacks) so the services report it; declares ``name`` unchecked when it is new."""
        if name not in self._descriptors:
            self._descriptors[name] = ParameterDescriptor(name, value, None)
        self._values[name] = value

    def undeclare(self, name: str) -> None:
        self._descriptors.pop(name, None)
        self._values.pop(name, None)

    def add_on_set_callback(self, callback: Callable[[str, Any], str | None]) -> None:
        self._callbacks.append(callback)

    # ---------------------------------------------------------------- the services
    def serve(self, create_service: Callable[..., Any]) -> None:
        """Offer ``~/get_parameters`` and ``~/set_parameters`` through the node's ``create_service``."""
        create_service(GetParameters, "~/get_parameters", self._srv_get)
        create_service(SetParameters, "~/set_parameters", self._srv_set)

    def _srv_get(self, request: Any) -> Any:
        wanted = request.names or sorted(self._values)
        found = [n for n in wanted if n in self._values]
        return GetParameters.Response(names=found, values_yaml=[dump_value(self._values[n]) for n in found])

    def _srv_set(self, request: Any) -> Any:
        if len(request.names) != len(request.values_yaml):
            raise ValueError(f"{len(request.names)} names but {len(request.values_yaml)} values")
        ok, reasons = [], []
        for name, text in zip(request.names, request.values_yaml, strict=True):
            try:
                self.set(name, parse_value(text))
                ok.append(True)
                reasons.append("")
            except ParameterError as exc:
                ok.append(False)
                reasons.append(str(exc))
        return SetParameters.Response(successful=ok, reasons=reasons)
