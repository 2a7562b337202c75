"""Every bash and python example in README.md and the docs pages runs as written against a live job.

The convention (docs/contributing.md, "The examples in these docs are tested"): every ```bash and ```python
block, and the zenroid column of the table after ``<!-- examples: table -->``, run in order (the README, then
the pages in the site's nav order; the pages that act on the job's physics in one lane, the others in a
second lane beside it) from a copy of the repository root, against ``python -m launch
humanoid.yaml gui:=false`` (``job=FILE.yaml`` in the block's info string picks another launch file), each
job started once for all its examples. A bash command, or a whole python block, must exit 0; one whose
comment says ``(until Ctrl-C)`` must still be running after a few seconds and then end on SIGINT;
``(not tested: …)`` skips it, and so does a block whose info string says ``notest`` (its reason: a
``# (not tested: …)`` comment in it); a reason that names ``tests/integration/test_x.py::test_y`` says
which test runs the example instead, and that test must exist. Python blocks find the
job's router in ``ZENOH_CONNECT``.
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
import yaml

from tests.conftest import ROOT, free_port

MAIN_JOB = "humanoid.yaml"
NAMESPACES = {"humanoid.yaml": "humanoid", "controller_lab.yaml": "simple_robot"}
RUN_LANGUAGES = ("bash", "python")
STREAM_SECONDS = 2.0
_FENCE = re.compile(r"^```(\S*)[ \t]*(.*)$")
_CODE_SPAN = re.compile(r"`([^`]+)`")
_HEREDOC = re.compile(r"<<-?\s*['\"]?(\w+)['\"]?")


def _nav_pages(nav: list) -> list[str]:
    pages: list[str] = []
    for item in nav:
        value = next(iter(item.values())) if isinstance(item, dict) else item
        if isinstance(value, list):
            pages += _nav_pages(value)
        elif isinstance(value, str) and value.endswith(".md"):
            pages.append(value)
    return pages


def doc_pages() -> list[Path]:
    """README.md, then docs/*.md in the site's nav order (pages missing from the nav last, by name)."""
    nav = _nav_pages(yaml.safe_load((ROOT / "mkdocs.yml").read_text())["nav"])
    in_nav = [ROOT / "docs" / page for page in nav if (ROOT / "docs" / page).is_file()]
    rest = sorted(p for p in (ROOT / "docs").glob("*.md") if p not in in_nav)
    return [ROOT / "README.md", *in_nav, *rest]


@dataclass
class Example:
    page: str
    line: int
    command: str
    language: str = "bash"
    job: str = MAIN_JOB
    streaming: bool = False
    skip: str = ""
    attrs: dict[str, str] = field(default_factory=dict)

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"


def _markers(text: str) -> tuple[bool, str]:
    skip = re.search(r"\(not tested[^)]*\)", text)
    return "(until Ctrl-C)" in text, (skip.group(0) if skip else "")


_COVERING_TEST = re.compile(r"(tests/integration/test_\w+\.py)::(test_\w+)")


def covered_by(example: Example) -> str | None:
    """The test that runs a skipped example, when its reason names one (``(not tested: its own job;
    tests/integration/test_x.py::test_y runs it)``); a reason naming a test that does not exist fails."""
    named = _COVERING_TEST.search(example.skip)
    if named is None:
        return None
    path, test = named.groups()
    assert re.search(rf"^def {test}\(", (ROOT / path).read_text(), re.M), \
        f"{example.where}: its reason names {path}::{test}, which does not exist"
    return named.group(0)


def extract(text: str, page: str = "README.md") -> list[Example]:
    """A page's examples in document order: bash commands (joined over backslash continuations), whole python
    blocks, and the commands of an examples table."""
    examples: list[Example] = []
    lines = text.splitlines()
    in_block, language, job, block_skip = False, "", MAIN_JOB, ""
    pending: list[str] = []
    heredoc_end: str | None = None   # a bash here-document's terminator while its lines are being read
    start = 0
    in_table = False

    def close_python_block() -> None:
        source = "\n".join(pending)
        if source.strip():
            streaming, skip = _markers(source)
            examples.append(Example(page, start, source + "\n", "python", job, streaming, block_skip or skip))

    for number, line in enumerate(lines, start=1):
        fence = _FENCE.match(line)
        if fence:
            if in_block:
                if language == "python":
                    close_python_block()
                in_block, pending = False, []
                continue
            in_block = True
            attrs = dict(tok.split("=", 1) if "=" in tok else (tok, "") for tok in fence.group(2).split())
            language = fence.group(1) if fence.group(1) in RUN_LANGUAGES else ""
            job = attrs.get("job", MAIN_JOB)
            block_skip = f"(not tested: ```{language} notest)" if "notest" in attrs else ""
            start = number + 1
            continue
        if in_block:
            if language == "python":
                pending.append(line)
                continue
            if language == "bash" and not pending and line.lstrip().startswith("#"):
                if (note := _markers(line)[1]) and block_skip.startswith("(not tested: ```"):
                    block_skip = note   # a notest block's own reason, said in its comment
                continue
            if language != "bash" or (not pending and not line.strip()):
                continue
            if not pending:
                start = number
            pending.append(line)
            if heredoc_end is None and (opened := _HEREDOC.search(line)):
                heredoc_end = opened.group(1)
            elif heredoc_end is not None and line.strip() == heredoc_end:
                heredoc_end = None
            if line.rstrip().endswith("\\") or heredoc_end is not None:
                continue
            command = "\n".join(pending)
            pending = []
            streaming, skip = _markers(command)
            examples.append(Example(page, start, command, "bash", job, streaming, skip or block_skip))
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
                    examples.append(Example(page, number, span, "bash", MAIN_JOB, streaming, skip))
    return examples


def all_examples() -> list[Example]:
    return [e for page in doc_pages() for e in extract(page.read_text(), str(page.relative_to(ROOT)))]


def test_the_docs_examples_are_found_with_their_markers() -> None:
    examples = all_examples()
    pages = {e.page for e in examples}
    assert {"README.md", "docs/cli.md", "docs/messages.md", "docs/nodes.md"} <= pages
    commands = [e.command for e in examples]
    assert any(c.startswith("zenroid action send_goal -f humanoid/joint_trajectory_controller") for c in commands)
    assert not any("{...}" in c for c in commands), "a placeholder example would not run"
    assert any(e.job == "controller_lab.yaml" for e in examples)
    install = next(e for e in examples if e.command.startswith("pip install -e . &&"))
    assert install.skip and install.page == "README.md"
    hz = next(e for e in examples if e.command.startswith("zenroid topic hz humanoid/joint_states") and e.streaming)
    assert not hz.skip
    table = [e for e in examples if e.command == "zenroid check_urdf robots/humanoid.urdf"]
    assert table and table[0].page == "docs/cli.md", "the ros2-to-zenroid table is part of the examples"
    python = [e for e in examples if e.language == "python"]
    assert any("ZENOH_CONNECT" in e.command and not e.skip for e in python), "a python block that connects"
    assert any(e.streaming and "run_node(" in e.command for e in python), "a node that spins until Ctrl-C"
    assert all(e.command.endswith("\n") and "```" not in e.command for e in python)
    tested = [e for e in examples if not e.skip]
    covered = [e for e in examples if e.skip and covered_by(e)]   # run by the test their reason names
    assert len(tested) >= 80 and len(tested) + len(covered) > 3 * (len(examples) - len(tested) - len(covered))


def test_a_fenced_block_is_one_python_example_with_its_markers() -> None:
    text = "\n".join([
        "```python", "import os", "", "print(os.environ['ZENOH_CONNECT'])", "```",
        "```python job=controller_lab.yaml", "run_node(X)  # (until Ctrl-C)", "```",
        "```python notest", "raise SystemExit(1)", "```",
        "```text", "$ zenroid node list", "```",
        "```bash", "zenroid node list  # (not tested: why)", "zenroid topic list \\", "  -t",
        "cat > /tmp/x.sdf <<'EOF'", "# not a comment here", "", "EOF", "zenroid spawn -file /tmp/x.sdf", "```",
    ])
    found = extract(text, "page.md")
    assert [(e.language, e.line, e.job, e.streaming, bool(e.skip)) for e in found] == [
        ("python", 2, MAIN_JOB, False, False), ("python", 7, "controller_lab.yaml", True, False),
        ("python", 10, MAIN_JOB, False, True), ("bash", 16, MAIN_JOB, False, True),
        ("bash", 17, MAIN_JOB, False, False), ("bash", 19, MAIN_JOB, False, False),
        ("bash", 23, MAIN_JOB, False, False)]
    assert found[0].command == "import os\n\nprint(os.environ['ZENOH_CONNECT'])\n"
    assert found[4].command == "zenroid topic list \\\n  -t"
    assert found[5].command == "cat > /tmp/x.sdf <<'EOF'\n# not a comment here\n\nEOF"


def _workspace(tmp_path: Path) -> tuple[Path, Path, dict[str, str]]:
    """A copy of the repository root (symlinks) to run in, a bin directory whose `python` and `zenroid` are
    this interpreter and this checkout, and the environment that puts it first."""
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
    return work, bin_dir, env


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


def _argv(example: Example, bin_dir: Path, scripts: Path) -> list[str]:
    if example.language == "bash":
        return ["bash", "-c", example.command]
    script = scripts / f"{example.page.replace('/', '_').removesuffix('.md')}_{example.line}.py"
    script.write_text(example.command)
    return [str(bin_dir / "python"), str(script)]


def _run(example: Example, work: Path, bin_dir: Path, env: dict[str, str], log_dir: Path) -> str:
    """'' when the example behaved as its page says, else what went wrong."""
    first_line = example.command.strip().splitlines()[0]
    where = f"{example.where}: {example.command if example.language == 'bash' else first_line + ' …'}"
    argv = _argv(example, bin_dir, log_dir)
    if not example.streaming:
        try:
            done = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=work, timeout=240)
        except subprocess.TimeoutExpired:
            return f"{where}\n  did not end within 240 s"
        if done.returncode != 0:
            return f"{where}\n  exit {done.returncode}\n{(done.stdout + done.stderr)[-2000:]}"
        return ""
    log = log_dir / f"stream-{example.line}-{time.monotonic_ns()}.log"
    with open(log, "wb") as out:
        proc = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, env=env, cwd=work, start_new_session=True)
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


# Verbs that only read: consecutive ones run concurrently (the pages' order still holds for everything that
# changes the job, which runs alone, after what precedes it and before what follows).
_READ_ONLY = re.compile(
    r"^(zenroid (node (list|info)|topic (list|echo|info|type|hz|bw)|service (list|type)|action (list|info)"
    r"|param (list|get)|lifecycle nodes|graph|doctor|check_urdf|urdf_to_graphviz|xacro|sim info"
    r"|control list_(controllers|hardware_interfaces))\b|python -m launch \S+ --show-args\s*(#.*)?$"
    r"|zenroid launch \S+ --print\s*(#.*)?$)")


# A python block that imports none of these does not reach the job (message classes, the codec).
_REACHES_THE_JOB = re.compile(r"\b(zenoh|nodes|launch)\b|ZENOH_")


def _read_only(e: Example) -> bool:
    if e.language == "python":
        return not e.streaming and not _REACHES_THE_JOB.search(e.command)
    return bool(_READ_ONLY.match(e.command)) and "\n" not in e.command


def _waves(examples: list[Example]) -> list[list[Example]]:
    """Consecutive read-only examples grouped (bash commands that only read, streaming ones such as `topic hz`
    included, and python blocks that do not reach the job); every other example is a wave of its own. An exact repeat of an earlier
    read-only command (the tour and the CLI page both list `node list`) is run once."""
    waves: list[list[Example]] = []
    seen: set[str] = set()
    for e in examples:
        read_only = _read_only(e)
        command = e.command.split("#")[0].strip() if e.language == "bash" else e.command
        if read_only and command in seen:
            continue
        if read_only:
            seen.add(command)
            if waves and waves[-1][0].attrs.get("read_only") == "yes":
                waves[-1].append(e)
                continue
            e.attrs["read_only"] = "yes"
        waves.append([e])
    return waves


# Pages whose examples act on the job's physics (pushes, gravity, pauses, resets, spawns, bag replays into the
# job) or read what it does (sensors): one lane, in page order. The other pages neither change what those read
# nor depend on it: they run in a second lane beside the first, in a workspace of their own.
_PHYSICS_PAGES = frozenset({"README.md", "docs/simulator.md", "docs/worlds.md", "docs/sensors.md", "docs/cli.md",
                            "docs/bags.md"})


def lanes(examples: list[Example]) -> list[list[Example]]:
    """The examples that touch the job's physics, and the rest; each keeps the pages' order."""
    return [[e for e in examples if e.page in _PHYSICS_PAGES], [e for e in examples if e.page not in _PHYSICS_PAGES]]


def _run_lane(examples: list[Example], lane_dir: Path, connect: str) -> list[str]:
    from concurrent.futures import ThreadPoolExecutor

    lane_dir.mkdir()
    work, bin_dir, env = _workspace(lane_dir)
    env["ZENOH_CONNECT"] = connect
    failures: list[str] = []
    with ThreadPoolExecutor(max_workers=3) as pool:
        for wave in _waves(examples):
            started = time.monotonic()
            failures += [p for p in pool.map(lambda e: _run(e, work, bin_dir, env, lane_dir), wave) if p]
            with open(lane_dir / "waves.tsv", "a") as timings:   # where the test's time goes
                timings.write(f"{time.monotonic() - started:.2f}\t{len(wave)}\t{wave[0].where}\n")
    return failures


@pytest.mark.slow
@pytest.mark.timeout(1200)
@pytest.mark.parametrize("job", [MAIN_JOB, "controller_lab.yaml"])
def test_docs_examples_run_as_written(job: str, tmp_path: Path) -> None:
    from concurrent.futures import ThreadPoolExecutor

    examples = [e for e in all_examples() if e.job == job and not e.skip]
    assert examples
    _, _, env = _workspace(tmp_path)
    port = free_port()
    log = tmp_path / "job.log"
    proc = _start_job(job, port, env, log)
    connect = env["ZENOH_CONNECT"] = f"tcp/127.0.0.1:{port}"
    failures: list[str] = []
    try:
        _wait_ready(job, env, proc, log)
        with ThreadPoolExecutor(max_workers=2) as pool:
            runs = [pool.submit(_run_lane, lane, tmp_path / f"lane{i}", connect)
                    for i, lane in enumerate(lanes(examples)) if lane]
            failures = [failure for run in runs for failure in run.result()]
    finally:
        _stop(proc)
    assert not failures, f"{len(failures)} of {len(examples)} docs examples failed:\n\n" + "\n\n".join(failures)
