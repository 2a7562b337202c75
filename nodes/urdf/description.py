"""Turn a file path or XML text (URDF or xacro) into URDF text, safely.

xacro is run in-process through the ``xacro`` package (no ROS needed); its ``$(find pkg)`` asks
``ament_index_python``, which is zenroid's package index (nodes/packages), and a package it does not know gets
a clear error naming it and the paths searched instead of a traceback.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from nodes.packages.index import PackageNotFoundError
from nodes.urdf.model import UrdfError
from nodes.urdf.xml_safety import UnsafeXmlError, check_xml_safety, xml_text


def parse_xacro_args(items: list[str] | tuple[str, ...] | str | None) -> dict[str, str]:
    """``["name:=value", ...]`` (or one space-separated string) -> mapping; bad items raise UrdfError."""
    if not items:
        return {}
    if isinstance(items, str):
        items = items.split()
    mapping: dict[str, str] = {}
    for item in items:
        if ":=" not in item:
            raise UrdfError(f"xacro argument '{item}' is not of the form name:=value")
        name, value = item.split(":=", 1)
        if not name.strip():
            raise UrdfError(f"xacro argument '{item}' has an empty name")
        mapping[name.strip()] = value
    return mapping


def is_xacro(text: str, path: str | None = None) -> bool:
    return bool(path and path.endswith(".xacro")) or "xmlns:xacro" in text


def _missing_package(exc: BaseException | None) -> PackageNotFoundError | None:
    """The package lookup that failed under a xacro error (xacro wraps the exception of ``$(find)``)."""
    seen = 0
    while exc is not None and seen < 10:
        if isinstance(exc, PackageNotFoundError):
            return exc
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return None


def _run_xacro(path: str, mappings: dict[str, str]) -> str:
    import xacro  # local import: only paid when a xacro file is used

    try:
        document = xacro.process_file(path, mappings=mappings)
    except Exception as exc:
        missing = _missing_package(exc)
        if missing is not None:
            raise UrdfError(f"xacro failed on {path}: $(find {missing.package}): {missing}") from None
        if isinstance(exc, xacro.XacroException):
            raise UrdfError(f"xacro failed on {path}: {exc}") from None
        # xacro raises plain exceptions for XML and expression errors
        raise UrdfError(f"xacro failed on {path}: {type(exc).__name__}: {exc}") from None
    return document.toprettyxml(indent="  ")


def load_robot_description(
    path: str | os.PathLike | None = None,
    xml: str | None = None,
    xacro_args: dict[str, str] | None = None,
) -> str:
    """URDF text from a file (``.urdf`` or ``.xacro``) or from XML text; xacro is expanded with the args."""
    mappings = dict(xacro_args or {})
    if path is not None:
        file = Path(path)
        if "://" in str(path):   # package://pkg/urdf/robot.urdf.xacro, file:///..., as robot_file:= takes them
            from nodes.urdf.paths import robot_uri_path

            file = robot_uri_path(str(path)) or file
        if not file.is_file():
            raise UrdfError(f"robot description file '{file}' does not exist")
        try:
            text = xml_text(file.read_bytes())
        except (OSError, ValueError) as exc:
            raise UrdfError(f"cannot read '{file}': {exc}") from None
        source = str(file)
    elif xml is not None:
        text, source = xml, None
    else:
        raise UrdfError("no robot description given (need a file path or XML text)")
    try:
        check_xml_safety(text)
    except UnsafeXmlError as exc:
        raise UrdfError(str(exc)) from None
    if not is_xacro(text, source):
        return text  # like the xacro tool, args that nothing uses are simply ignored
    if source is None:
        # xacro works on files; a parameter holding xacro text goes through a private temporary file.
        with tempfile.NamedTemporaryFile("w", suffix=".urdf.xacro", delete=False, encoding="utf-8") as tmp:
            tmp.write(text)
        try:
            expanded = _run_xacro(tmp.name, mappings)
        finally:
            os.unlink(tmp.name)
    else:
        expanded = _run_xacro(source, mappings)
    try:
        check_xml_safety(expanded)
    except UnsafeXmlError as exc:
        raise UrdfError(f"after xacro expansion: {exc}") from None
    return expanded
