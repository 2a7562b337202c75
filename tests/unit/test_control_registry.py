"""Controller types come from a registry (built-ins + the ``zenroid.controllers`` entry-point group): a
type named by a request is never imported."""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

from nodes.control import controllers
from nodes.control.config import ConfigError, parse_config
from nodes.control.controller import Controller
from nodes.control.controllers import CONTROLLER_TYPES, controller_class, known_types

ROOT = Path(__file__).resolve().parents[2]


def test_builtin_types_resolve() -> None:
    from nodes.control.controllers.joint_trajectory_controller import JointTrajectoryController

    assert controller_class("joint_trajectory_controller/JointTrajectoryController") is JointTrajectoryController
    assert set(CONTROLLER_TYPES) <= set(known_types())


@pytest.mark.parametrize("name", ["this:Nope", "os:system", "antigravity:Fly", "os.path:join", "../x/Y", "",
                                  "subprocess/Popen", "x" * 100_000])
def test_unknown_types_are_refused_without_importing(name: str) -> None:
    code = f"""
import sys
from nodes.control.controllers import controller_class
before = set(sys.modules)
try:
    controller_class({name!r})
except KeyError as exc:
    text = str(exc.args[0])
    assert len(text) < 2000, len(text)
    print("refused:", text[:200])
else:
    raise SystemExit("accepted")
new = set(sys.modules) - before
assert not {{"this", "antigravity", "subprocess"}} & new, new
"""
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert out.returncode == 0, out.stderr
    assert "refused:" in out.stdout
    assert "Beautiful is better than ugly" not in out.stdout   # `import this` would print the Zen of Python


def test_registered_entry_point_loads_only_by_its_name(monkeypatch: pytest.MonkeyPatch) -> None:
    class Plugged(Controller):
        type_name = "my_controllers/Plugged"

    loaded: list[str] = []

    class FakeEntryPoint:
        def __init__(self, name: str, value: str, target: object) -> None:
            self.name, self.value, self._target = name, value, target

        def load(self) -> object:
            loaded.append(self.name)
            return self._target

    points = [FakeEntryPoint("my_controllers/Plugged", "pkg.mod:Plugged", Plugged),
              FakeEntryPoint("my_controllers/NotAController", "pkg.mod:thing", object())]
    monkeypatch.setattr(controllers, "_entry_points", lambda: points)
    assert controller_class("my_controllers/Plugged") is Plugged
    assert loaded == ["my_controllers/Plugged"]
    with pytest.raises(KeyError, match="not a Controller subclass"):
        controller_class("my_controllers/NotAController")
    with pytest.raises(KeyError, match="unknown controller type"):
        controller_class("my_controllers/Other")
    assert loaded == ["my_controllers/Plugged", "my_controllers/NotAController"]
    assert "my_controllers/Plugged" in known_types()


def test_pyproject_declares_every_builtin_in_the_entry_point_group() -> None:
    tomllib = pytest.importorskip("tomllib")   # Python 3.11+
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    declared = project["entry-points"][controllers.ENTRY_POINT_GROUP]
    assert set(declared) == set(CONTROLLER_TYPES)
    for name, value in declared.items():
        ep = metadata.EntryPoint(name=name, value=value, group=controllers.ENTRY_POINT_GROUP)
        assert ep.load() is CONTROLLER_TYPES[name]


def test_config_refuses_module_paths_as_types() -> None:
    with pytest.raises(ConfigError, match="package/Class"):
        parse_config({"controller_manager": {"ros__parameters": {"c": {"type": "os:system"}}}})
