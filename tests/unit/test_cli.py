"""The zenroid dispatcher: verbs, exit codes, closed pipes."""

from __future__ import annotations

import subprocess
import sys

from nodes.tools.cli import VERBS, main
from tests.conftest import ROOT


def test_unknown_verb_exits_2(capsys) -> None:
    assert main(["frobnicate"]) == 2
    assert "unknown verb 'frobnicate'" in capsys.readouterr().err


def test_help_lists_every_verb(capsys) -> None:
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert all(verb in out for verb in VERBS)


def _star_urdf(links: int) -> str:
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>'
                '</inertial><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>')
    parts = [f'<robot name="star"><link name="base">{inertial}</link>']
    for i in range(links):
        parts.append(f'<link name="leaf_with_a_long_name_{i}">{inertial}</link>'
                     f'<joint name="j{i}" type="fixed"><parent link="base"/><child link="leaf_with_a_long_name_{i}"/>'
                     "</joint>")
    return "".join(parts) + "</robot>"


def test_closed_pipe_ends_quietly(tmp_path) -> None:
    urdf = tmp_path / "star.urdf"
    urdf.write_text(_star_urdf(4000))  # its tree printout is larger than a pipe buffer
    proc = subprocess.Popen([sys.executable, "-m", "nodes.tools", "check_urdf", str(urdf)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None
    proc.stdout.readline()
    proc.stdout.close()  # like `| head -1`
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0
    assert b"Traceback" not in err
