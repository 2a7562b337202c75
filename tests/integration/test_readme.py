"""Every shell example in README.md runs as written against a live job.

The README's convention (stated in its Command line section): every ```bash block and the zenroid column
of the table after ``<!-- examples: table -->`` are run in order, with bash, from a copy of the repository
root, against ``python -m launch humanoid.yaml gui:=false`` (``job=FILE.yaml`` in the block's info string
picks another launch file); each command must exit 0. A command whose comment says ``(until Ctrl-C)`` must
still be running after a few seconds and then end on SIGINT; ``(not tested: …)`` skips it, and so does a
```bash notest block.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from tests.conftest import ROOT, free_port

README = ROOT / "README.md"
MAIN_JOB = "humanoid.yaml"
NAMESPACES = {"humanoid.yaml": "humanoid", "controller_lab.yaml": "simple_robot"}
STREAM_SECONDS = 3.0
_FENCE = re.compile(r"^```(\S*)[ \t]*(.*)$")
_CODE_SPAN = re.compile(r"`([^`]+)`")


@dataclass
class Example:
    line: int
    command: str
    job: str = MAIN_JOB
    streaming: bool = False
    skip: str = ""
    attrs: dict[str, str] = field(default_factory=dict)


def _markers(text: str) -> tuple[bool, str]:
    skip = re.search(r"\(not tested[^)]*\)", text)
    return "(until Ctrl-C)" in text, (skip.group(0) if skip else "")


def extract(text: str) -> list[Example]:
    """The README's shell examples in document order (commands joined over backslash continuations)."""
    examples: list[Example] = []
    lines = text.splitlines()
    in_block, run_block, job, block_skip = False, False, MAIN_JOB, ""
    pending: list[str] = []
    start = 0
    in_table = False
    for number, line in enumerate(lines, start=1):
        fence = _FENCE.match(line)
        if fence:
            if in_block:
                in_block = False
                continue
            in_block = True
            attrs = dict(tok.split("=", 1) if "=" in tok else (tok, "") for tok in fence.group(2).split())
            run_block = fence.group(1) == "bash"
            job = attrs.get("job", MAIN_JOB)
            block_skip = "(not tested: ```bash notest)" if "notest" in attrs else ""
            continue
        if in_block:
            if not run_block:
                continue
            if not pending and (not line.strip() or line.lstrip().startswith("#")):
                continue
            if not pending:
                start = number
            pending.append(line)
            if line.rstrip().endswith("\\"):
                continue
            command = "\n".join(pending)
            pending = []
            streaming, skip = _markers(command)
            examples.append(Example(start, command, job, streaming, block_skip or skip))
            continue
        if line.strip() == "<!-- examples: table -->":
            in_table = True
            continue
        if in_table:
            if not line.startswith("|"):
                if examples and line.strip():
                    in_table = False
                continue
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if set("".join(cells)) <= set("-: ") or cells[0].startswith("tutorial"):
                continue  # header and separator rows
            cell = cells[-1]
            streaming, skip = _markers(cell)
            for span in _CODE_SPAN.findall(cell):
                if span.startswith(("zenroid ", "python ")):
                    examples.append(Example(number, span, MAIN_JOB, streaming, skip))
    return examples


def test_the_readme_examples_are_found_with_their_markers() -> None:
    examples = extract(README.read_text())
    commands = [e.command for e in examples]
    assert any(c.startswith("zenroid action send_goal -f humanoid/joint_trajectory_controller") for c in commands)
    assert not any("{...}" in c for c in commands), "a placeholder example would not run"
    assert any(e.job == "controller_lab.yaml" for e in examples)
    install = next(e for e in examples if e.command.startswith("pip install -e . &&"))
    assert install.skip
    hz = next(e for e in examples if e.command.startswith("zenroid topic hz humanoid/joint_states "))
    assert hz.streaming and not hz.skip
    table = [e for e in examples if e.command == "zenroid check_urdf robots/humanoid.urdf"]
    assert table, "the seeds-to-zenroid table is part of the examples"
    tested = [e for e in examples if not e.skip]
    assert len(tested) >= 60 and len(tested) > 4 * len([e for e in examples if e.skip])


def _workspace(tmp_path: Path) -> tuple[Path, dict[str, str]]:
    """A copy of the repository root (symlinks) to run in, and an environment whose `python` and `zenroid`
    are this interpreter and this checkout."""
    work = tmp_path / "work"
    work.mkdir()
    for entry in ROOT.iterdir():
        if not entry.name.startswith("."):
            (work / entry.name).symlink_to(entry)
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    # Scripts, not links: CPython finds a venv's pyvenv.cfg beside the path it was started by, so a link to
    # the venv's interpreter would run outside the venv (without its packages).
    for name, command in (("python", f'"{sys.executable}"'), ("zenroid", f'"{sys.executable}" -m nodes.tools')):
        script = bin_dir / name
        script.write_text(f'#!/bin/sh\nexec {command} "$@"\n')
        script.chmod(0o755)
    env = dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}", PYTHONPATH=str(ROOT),
               PYTHONUNBUFFERED="1", ZENROID_LOG_DIR=str(tmp_path / "logs"))
    env.pop("ZENOH_CONFIG", None)
    env.pop("ZENOH_CONNECT", None)
    return work, env


def _start_job(job: str, port: int, env: dict[str, str], log: Path) -> subprocess.Popen:
    with open(log, "wb") as out:
        return subprocess.Popen([sys.executable, "-m", "launch", job, "gui:=false", f"zenoh_port:={port}"],
                                stdout=out, stderr=subprocess.STDOUT, env=env, cwd=ROOT, start_new_session=True)


def _wait_ready(job: str, env: dict[str, str], proc: subprocess.Popen, log: Path) -> None:
    """Ready when the job's trajectory controller is active (its spawners are done)."""
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"{job} exited with {proc.returncode}:\n{log.read_text()[-3000:]}")
        done = subprocess.run([sys.executable, "-m", "nodes.tools", "control", "list_controllers", "--ns",
                               NAMESPACES[job]], capture_output=True, text=True, env=env, cwd=ROOT, timeout=60)
        if re.search(r"joint_trajectory_controller\s+\S+\s+active", done.stdout):
            return
        time.sleep(1.0)
    pytest.fail(f"{job} not ready after 180 s:\n{log.read_text()[-3000:]}")


def _stop(proc: subprocess.Popen, grace: float = 20.0) -> bool:
    """SIGINT to the process group (Ctrl-C); True when it ended within ``grace`` s."""
    try:
        os.killpg(proc.pid, signal.SIGINT)
    except ProcessLookupError:
        return True
    try:
        proc.wait(grace)
        return True
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        return False


def _run(example: Example, work: Path, env: dict[str, str], log_dir: Path) -> str:
    """'' when the example behaved as the README says, else what went wrong."""
    where = f"README.md:{example.line}: {example.command}"
    if not example.streaming:
        try:
            done = subprocess.run(["bash", "-c", example.command], capture_output=True, text=True, env=env,
                                  cwd=work, timeout=240)
        except subprocess.TimeoutExpired:
            return f"{where}\n  did not end within 240 s"
        if done.returncode != 0:
            return f"{where}\n  exit {done.returncode}\n{(done.stdout + done.stderr)[-2000:]}"
        return ""
    log = log_dir / f"stream-{example.line}-{time.monotonic_ns()}.log"
    with open(log, "wb") as out:
        proc = subprocess.Popen(["bash", "-c", example.command], stdout=out, stderr=subprocess.STDOUT, env=env,
                                cwd=work, start_new_session=True)
    # Runs at least STREAM_SECONDS and until it printed something (a loaded machine may take long to import
    # rerun or DART; a Ctrl-C during an import is Python's own traceback, not the program's).
    started = time.monotonic()
    while proc.poll() is None and time.monotonic() - started < 60 and (
            time.monotonic() - started < STREAM_SECONDS or log.stat().st_size == 0):
        time.sleep(0.2)
    if proc.poll() is not None:
        return f"{where}\n  ended with {proc.returncode} before Ctrl-C\n{log.read_text()[-2000:]}"
    if not _stop(proc):
        return f"{where}\n  still running 20 s after Ctrl-C\n{log.read_text()[-2000:]}"
    output = log.read_text(errors="replace")
    if "Traceback" in output:
        return f"{where}\n  printed a traceback\n{output[-2000:]}"
    return ""


# Verbs that only read: consecutive ones run concurrently (the README's order still holds for everything that
# changes the job, which runs alone, after what precedes it and before what follows).
_READ_ONLY = re.compile(
    r"^(zenroid (node (list|info)|topic (list|echo|info|type|hz|bw)|service (list|type)|action (list|info)"
    r"|param (list|get)|lifecycle nodes|graph|doctor|check_urdf|urdf_to_graphviz|xacro|sim info"
    r"|control list_(controllers|hardware_interfaces))\b|python -m launch \S+ --show-args\s*(#.*)?$"
    r"|zenroid launch \S+ --print\s*(#.*)?$)")


def _waves(examples: list[Example]) -> list[list[Example]]:
    """Consecutive read-only, non-streaming examples grouped; every other example is a wave of its own. An
    exact repeat of an earlier read-only command (the tour and the reference both list `node list`) is
    run once."""
    waves: list[list[Example]] = []
    seen: set[str] = set()
    for e in examples:
        read_only = not e.streaming and bool(_READ_ONLY.match(e.command)) and "\n" not in e.command
        if read_only and e.command.split("#")[0].strip() in seen:
            continue
        if read_only:
            seen.add(e.command.split("#")[0].strip())
            if waves and waves[-1][0].attrs.get("read_only") == "yes":
                waves[-1].append(e)
                continue
            e.attrs["read_only"] = "yes"
        waves.append([e])
    return waves


@pytest.mark.slow
@pytest.mark.timeout(900)
@pytest.mark.parametrize("job", [MAIN_JOB, "controller_lab.yaml"])
def test_readme_examples_run_as_written(job: str, tmp_path: Path) -> None:
    from concurrent.futures import ThreadPoolExecutor

    examples = [e for e in extract(README.read_text()) if e.job == job and not e.skip]
    assert examples
    work, env = _workspace(tmp_path)
    port = free_port()
    log = tmp_path / "job.log"
    proc = _start_job(job, port, env, log)
    env["ZENOH_CONNECT"] = f"tcp/127.0.0.1:{port}"
    failures: list[str] = []
    try:
        _wait_ready(job, env, proc, log)
        with ThreadPoolExecutor(max_workers=3) as pool:
            for wave in _waves(examples):
                failures += [p for p in pool.map(lambda e: _run(e, work, env, tmp_path), wave) if p]
    finally:
        _stop(proc)
    assert not failures, f"{len(failures)} of {len(examples)} README examples failed:\n\n" + "\n\n".join(failures)
