"""``zenroid check_urdf`` / ``zenroid xacro``: exit codes and messages on good, broken and hostile files."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from nodes.tools.cli import main
from nodes.urdf import UrdfError, load_robot_description, parse_urdf

ROOT = Path(__file__).resolve().parents[2]
BROKEN = ROOT / "tests" / "data" / "urdf_broken"
ROBOT_FILES = sorted((ROOT / "robots").glob("*.urdf")) + sorted((ROOT / "robots").glob("*.xacro"))

# file -> (exit status, text the one-line reason must contain)
EXPECTED = {
    "missing_parent_link.urdf": (2, "joint 'j1': parent link 'ghost' does not exist"),
    "missing_child_link.urdf": (2, "joint 'j1': child link 'ghost' does not exist"),
    "cycle.urdf": (2, "closes a loop (cycle)"),
    "pure_cycle.urdf": (2, "kinematic loop through link"),
    "several_roots.urdf": (2, "several root links: base, other"),
    "duplicate_link.urdf": (2, "duplicate link name 'a'"),
    "duplicate_joint.urdf": (2, "duplicate joint name 'j1'"),
    "link_name_wildcard.urdf": (2, "link 'a/*/b': has '*'"),
    "limits_inverted.urdf": (2, "joint 'j1': lower limit 1.5 > upper limit -1.5"),
    "zero_mass.urdf": (2, "link 'a': mass 0 is not positive"),
    "negative_mass.urdf": (2, "link 'a': mass -2 is not positive"),
    "inertia_not_positive_definite.urdf": (2, "link 'a': inertia is not positive definite"),
    "revolute_without_limit.urdf": (2, "a revolute joint needs a <limit>"),
    "bad_number.urdf": (2, "<origin xyz='0 zero 1'> is not a number"),
    "nan_origin.urdf": (2, "is not finite"),
    "unknown_joint_type.urdf": (2, "unknown type 'hinge'"),
    "malformed.urdf": (2, "XML syntax error"),
    "billion_laughs.urdf": (2, "declares entities"),
    "external_entity.urdf": (2, "declares entities"),
    "external_dtd.urdf": (2, "external DTD"),
    "no_inertia.urdf": (0, "warning: link 'a' has no <inertial>"),
}


def test_every_broken_file_has_an_expectation() -> None:
    assert sorted(p.name for p in BROKEN.glob("*.urdf")) == sorted(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_check_urdf_on_broken_file(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    status, text = EXPECTED[name]
    assert main(["check_urdf", str(BROKEN / name)]) == status
    err = capsys.readouterr().err
    assert text in err
    if status == 2:
        assert err.count("\n") == 1 and err.startswith("zenroid check_urdf: ")  # one line


@pytest.mark.parametrize("path", ROBOT_FILES, ids=lambda p: p.name)
def test_check_urdf_passes_every_robot_silently(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check_urdf", str(path)]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert out.startswith("robot name is: ")
    model = parse_urdf(load_robot_description(path))
    assert f"root Link: {model.root} has {len(model.children_of(model.root))} child(ren)" in out
    assert out.count("child(") == len(model.joints) + 1  # one line per link below the root + root line


def test_check_urdf_prints_the_module2_tree_like_ros(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check_urdf", str(ROOT / "robots" / "humanoid_simplified.urdf")]) == 0
    assert capsys.readouterr().out.splitlines() == [
        "robot name is: humanoid_simplified",
        "---------- Successfully Parsed XML ---------------",
        "root Link: base_link has 2 child(ren)",
        "    child(1):  left_upper_arm",
        "        child(1):  left_forearm",
        "            child(1):  left_hand",
        "    child(2):  right_upper_arm",
        "        child(1):  right_forearm",
        "            child(1):  right_hand",
    ]


def test_check_urdf_missing_file_and_bad_xacro_arg_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check_urdf", "no/such/file.urdf"]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["check_urdf", str(ROOT / "robots" / "simple_robot.urdf.xacro"), "length"]) == 2
    assert "not of the form name:=value" in capsys.readouterr().err


def test_xacro_expands_with_args_and_writes_a_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = str(ROOT / "robots" / "simple_robot.urdf.xacro")
    assert main(["xacro", source, "length:=0.5"]) == 0
    out = capsys.readouterr().out
    assert '<cylinder length="0.5" radius="0.05"/>' in out and "xacro:" not in out
    target = tmp_path / "out.urdf"
    assert main(["xacro", source, "-o", str(target)]) == 0
    assert parse_urdf(target.read_text()).name == "simple_robot"


def test_xacro_refuses_entities_and_reports_xacro_errors(tmp_path: Path, capsys) -> None:
    hostile = tmp_path / "evil.urdf.xacro"
    hostile.write_text((BROKEN / "external_entity.urdf").read_text().replace(
        '<robot name="leak">', '<robot name="leak" xmlns:xacro="http://www.ros.org/wiki/xacro">'))
    assert main(["xacro", str(hostile)]) == 2
    assert "declares entities" in capsys.readouterr().err
    broken = tmp_path / "broken.urdf.xacro"
    broken.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="${nope}"/></robot>')
    assert main(["xacro", str(broken)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("zenroid xacro: xacro failed on") and "nope" in err


def test_entities_in_a_description_string_are_refused() -> None:
    text = (BROKEN / "billion_laughs.urdf").read_text()
    with pytest.raises(UrdfError, match="declares entities"):
        load_robot_description(xml=text)
    with pytest.raises(UrdfError, match="declares entities"):
        parse_urdf(text)


def test_cli_process_exit_codes() -> None:
    """The real command line in a fresh interpreter (no pytest capture)."""
    run = [sys.executable, "-c", "import sys; from nodes.tools.cli import main; sys.exit(main())"]
    ok = subprocess.run(run + ["check_urdf", "robots/humanoid.urdf"], cwd=ROOT, capture_output=True, text=True)
    assert ok.returncode == 0 and "root Link: pelvis has 3 child(ren)" in ok.stdout
    bad = subprocess.run(run + ["check_urdf", str(BROKEN / "several_roots.urdf")], cwd=ROOT, capture_output=True,
                         text=True)
    assert bad.returncode == 2 and bad.stderr.strip().endswith("(a URDF must be one tree)")


def test_xacro_text_given_as_a_parameter_is_expanded_with_args() -> None:
    text = (ROOT / "robots" / "simple_robot.urdf.xacro").read_text()
    model = parse_urdf(load_robot_description(xml=text, xacro_args={"length": "0.6"}))
    assert model.links["link1"].inertial.origin[0, 3] == pytest.approx(0.3)


def test_utf16_entity_attack_is_refused_not_expanded(tmp_path: Path, capsys) -> None:
    text = (BROKEN / "billion_laughs.urdf").read_text().replace(
        '<?xml version="1.0"?>', '<?xml version="1.0" encoding="UTF-16"?>')
    hostile = tmp_path / "utf16.urdf"
    hostile.write_bytes(text.encode("utf-16"))  # with a byte order mark: a bytes-level check would miss it
    assert main(["check_urdf", str(hostile)]) == 2
    assert "declares entities" in capsys.readouterr().err
    with pytest.raises(UrdfError, match="declares entities"):
        parse_urdf(text.encode("utf-16"))
    no_bom = tmp_path / "nobom.urdf"
    no_bom.write_bytes(text.encode("utf-16-le"))
    assert main(["check_urdf", str(no_bom)]) == 2
    assert "NUL characters" in capsys.readouterr().err
    legit = tmp_path / "legit16.urdf"
    legit.write_bytes((ROOT / "robots" / "simple_2dof_arm.urdf").read_text().replace(
        '<?xml version="1.0"?>', '<?xml version="1.0" encoding="UTF-16"?>').encode("utf-16"))
    assert main(["check_urdf", "-q", str(legit)]) == 0
