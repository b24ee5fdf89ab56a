"""Every command in the docs still runs.

Finds the shell commands in the fenced code blocks of README.md, docs/*.md and sim/README.md
(```bash / ```sh / ```console / plain ```, with or without a `$ ` prompt) that start with
`tactile-bt`, `python` or `pip install`, and:

- runs each one that takes under a minute, as its own test case (id = file:line), with
  cwd = the repository root and the venv's `tactile-bt` first on PATH; every output argument
  (`--out`, `--png`, `--record`, `--dot`) is redirected into pytest's tmp_path, and so is every
  later use of that path in the same block, so the repository is never written to. Nothing else
  is changed: a command too slow to run goes to NOT_RUN, it is never shortened;
- runs a command that uses the output of an earlier one in the same block (its directory, its
  recording, the pty the emulator prints) after that one, in the same test case;
- stops the commands the docs say run until Ctrl-C (UNTIL_STOPPED) with that signal, and checks
  they exit cleanly;
- checks `pip install ...` only statically: what it installs is this repository, with extras
  that exist in pyproject.toml (CI's own install runs it);
- requires every command found to be listed either in MEASURED_S (run; seconds measured by hand)
  or in NOT_RUN (with the reason), so a new command in the docs fails here until someone has
  timed it or said why it cannot run; and the measured total stays under BUDGET_S.

Budget: the whole file takes about 70 s on 2 cores; most of it is the surface scan (26 s).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DOC_FILES = ["README.md", *sorted(p.relative_to(REPO).as_posix() for p in (REPO / "docs").glob("*.md")),
             "sim/README.md"]
COMMAND_STARTS = ("tactile-bt", "python", "pip install")
SHELL_LANGUAGES = {"", "bash", "sh", "shell", "console", "zsh"}
OUTPUT_OPTIONS = ("--out", "--png", "--record", "--dot", "--rerun")
TIMEOUT_S = 120
BUDGET_S = 90

# A key below is "file:line", a whole command as the doc writes it (without its `$ ` prompt, its
# trailing comment and a leading `pip install ... &&`), or the first words of commands.

# Seconds measured by hand, once each, on the 2-core machine, before this file ran them:
#   `time tactile-bt ...` from the repository root with the output in /tmp.
MEASURED_S = {
    # README.md, the quick start (run 7.4 s + view --png)
    "tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --out out/cable"
    " && tactile-bt view out/cable --png out/cable/render.png": 7.4,
    # README.md, `sensor emulate` alone: up until it has printed its pty, then SIGTERM
    "tactile-bt sensor emulate": 1.2,
    # docs/hardware.md, one case: emulate, stream (2.5 s, Ctrl-C), record (2 s, SIGTERM), replay
    "tactile-bt sensor emulate --rate 1900 --faults garbage=0.01,tear=0.01": 0.2,
    "tactile-bt sensor stream /dev/pts/7": 2.7,
    "tactile-bt sensor record /dev/pts/7 --out run.tbr": 2.5,
    "tactile-bt sensor replay run.tbr --speed 2": 1.4,
    # docs/scanning.md
    "tactile-bt run trees/surface_scan_stripes.yaml --scene sim/scan_box.yaml --out out/scan_box": 26.0,
    # docs/trees.md
    "tactile-bt tree trees/hybrid.yaml": 0.5,
    "tactile-bt tree trees/hybrid.yaml --params": 0.4,
    "tactile-bt tree trees/hybrid.yaml --dot h.dot": 0.5,
    "tactile-bt run trees/hybrid.yaml --scene sim/cable.yaml --out out/hybrid": 4.7,
    'tactile-bt run trees/hybrid.yaml --scene sim/cable.yaml --param force_hold.target_pa="1.5 kPa"'
    " --out out/h15": 4.5,
    'tactile-bt run trees/force_hold.yaml --scene sim/pen.yaml --param force_hold.target_pa="1.5 kPa"'
    " --out out/p15": 4.5,
    "tactile-bt run trees/force_hold.yaml --scene sim/pen.yaml --param force_hold.kp=5e-5"
    " --param touch.timeout_s=5 --out out/kp": 4.3,
    "tactile-bt run examples/slide_and_record.yaml --scene sim/cable.yaml --blackboard /goal/pressure=1800"
    " --out out/slide": 3.2,
    'tactile-bt tree trees/force_hold.yaml --params --param force_hold.target_pa="1.5 kPa"': 0.4,
    # README.md, Studies: a local Dask cluster of one worker per core (2 here), then the rerun
    # that skips every run; docs/studies.md: the same in this process
    "tactile-bt sweep studies/pen_stiffness.yaml --out out/pen_stiffness": 4.0,
    "tactile-bt sweep studies/pen_stiffness.yaml --out out/pen_stiffness --workers 1": 3.3,
    # docs/watching.md, one case: the cable mission with a rerun recording, again with seed 1, and
    # their comparison. Measured while other work loaded both cores: these are the CPU times
    # (user + sys; wall times there were 8.1, 4.0 and 1.3 s)
    "tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --rerun out/cable.rrd --out out/cable": 4.0,
    "tactile-bt run trees/cable_follow.yaml --scene sim/cable.yaml --seed 1 --out out/cable_seed1": 2.4,
    "tactile-bt compare out/cable out/cable_seed1 --out out/compare": 0.8,
    # sim/README.md (my_scene.yaml: a copy of sim/pen.yaml, see PLACEHOLDER_FILES)
    "tactile-bt run trees/force_hold.yaml --scene my_scene.yaml --duration 2 --out /tmp/check": 1.8,
    # docs/writing_leaves.md: a leaf of one's own, imported with --plugin
    "tactile-bt tree examples/plugin/press.yaml --plugin examples/plugin/src/tactile_bt_press.py": 0.6,
}

NOT_RUN = {
    "ruff check && python -m pytest": "the linter and the whole test suite, this file included: minutes on 2 "
                                       "cores; CI runs it",
    "tactile-bt tree bad.yaml": "the doc shows the error but not bad.yaml itself; "
                                "tests/tree/test_loader.py and tests/package/test_cli.py check these messages",
    "tactile-bt sensor stream /dev/ttyACM0": "needs a tactile module on a serial port",
    "tactile-bt sensor record /dev/ttyACM0": "needs a tactile module on a serial port",
    "tactile-bt view out/scan_box": "opens a window (no --png)",
    "tactile-bt sweep bad.yaml": "the doc shows the error but not bad.yaml itself; tests/experiments/test_sweep.py checks "
                                 "these messages",
    "tactile-bt sweep studies/pen_stiffness.yaml --out out/sweep_cluster --scheduler": "needs a running "
        "'dask scheduler' and 'dask worker'; tests/experiments/test_sweep.py runs sweeps on an in-process LocalCluster",
    "tactile-bt run trees/scan_object.yaml": "a frontier scan runs 40-130 s of mission time, 15-60 s of wall time "
                                             "(docs/scanning.md gives each): too long for this file's budget",
    "tactile-bt view out/scan_object/object": "renders a scan of trees/scan_object.yaml, which is not run here",
    "tactile-bt live trees/cable_follow.yaml --sensor /dev/ttyACM0": "needs a tactile module and an arm",
    "tactile-bt twin sim/cable.yaml --out out/twin": "a server for the live command after it; tests/mission/test_live.py "
                                                     "runs the twin and live end to end, with their faults",
    "tactile-bt live trees/cable_follow.yaml --sensor /dev/pts/3": "needs the twin of the command before it "
                                                                   "(tests/mission/test_live.py)",
}

# Commands the docs say run until Ctrl-C or SIGTERM: (seconds to let them run, signal).
# None: a server for the commands after it; stopped with the signal at the end of the case.
UNTIL_STOPPED = {
    "tactile-bt sensor emulate": (None, signal.SIGTERM),
    "tactile-bt sensor stream": (2.5, signal.SIGINT),
    "tactile-bt sensor record": (2.0, signal.SIGTERM),
}

# Files the docs leave to the reader, made from the file the doc tells them to start from.
PLACEHOLDER_FILES = {
    "my_scene.yaml": "sim/pen.yaml",  # sim/README.md: "Copy the closest scene ..."
}


@dataclass
class DocCommand:
    file: str
    line: int
    text: str                                        # no prompt, no trailing comment
    shown: list[str] = field(default_factory=list)  # output lines the doc shows after it
    block: int = 0                                   # line of the block's opening fence

    @property
    def id(self) -> str:
        return f"{self.file}:{self.line}"

    @property
    def pip_segments(self) -> list[list[str]]:
        return [seg for seg, _ in _segments(self.text) if seg[:2] == ["pip", "install"]]

    @property
    def runnable(self) -> str:
        """The command without a leading `pip install ... &&` (checked, never run)."""
        text = self.text
        while m := re.match(r"pip install\b[^&|;]*&&\s*", text):
            text = text[m.end():]
        return "" if text.startswith("pip install") else text


def _strip_comment(line: str) -> str:
    quote, escaped = None, False
    for i, ch in enumerate(line):
        if escaped:
            escaped = False
        elif ch == "\\" and quote != "'":
            escaped = True
        elif quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip()
    return line.rstrip()


def _blocks(lines: list[str]):
    """(language, line of the opening fence, [(line number, text)]) of every fenced block."""
    fence = None
    for number, raw in enumerate(lines, 1):
        stripped = raw.strip()
        m = re.match(r"(`{3,}|~{3,})\s*([\w+-]*)\s*$", stripped)
        if fence is None:
            if m:
                fence, language, start, body = m.group(1), m.group(2).lower(), number, []
        elif m and stripped.startswith(fence) and not m.group(2):
            fence = None
            yield language, start, body
        else:
            body.append((number, stripped))


def find_commands() -> list[DocCommand]:
    commands = []
    for rel in DOC_FILES:
        for language, start, body in _blocks((REPO / rel).read_text(encoding="utf-8").splitlines()):
            if language not in SHELL_LANGUAGES:
                continue
            console = any(text.startswith("$ ") for _, text in body)  # lines without `$ ` are output
            previous, pending, pending_line = None, "", 0
            for number, text in body:
                if pending:                                              # a continued line
                    pending += " " + text
                else:
                    pending, pending_line = text, number
                if pending.endswith("\\"):
                    pending = pending[:-1].rstrip()
                    continue
                logical, pending = pending, ""
                prompt = logical.startswith("$ ")
                line = _strip_comment(logical[2:] if prompt else logical)
                if line.startswith(COMMAND_STARTS):
                    previous = DocCommand(rel, pending_line, line, block=start)
                    commands.append(previous)
                elif prompt:
                    previous = None
                elif console and previous is not None and line:
                    previous.shown.append(line)
    return commands


def _tokens(text: str) -> list[str]:
    lexer = shlex.shlex(text, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    return list(lexer)


def _is_operator(token: str) -> bool:
    return bool(token) and all(ch in "();<>|&" for ch in token)


def _segments(text: str) -> list[tuple[list[str], str]]:
    segments, current = [], []
    for token in _tokens(text):
        if _is_operator(token):
            segments.append((current, token))
            current = []
        else:
            current.append(token)
    segments.append((current, ""))
    return segments


def _outputs(text: str) -> list[str]:
    tokens, found = _tokens(text), []
    for i, token in enumerate(tokens):
        if token in OUTPUT_OPTIONS and i + 1 < len(tokens):
            found.append(tokens[i + 1])
        elif "=" in token and token.split("=", 1)[0] in OUTPUT_OPTIONS:
            found.append(token.split("=", 1)[1])
    return found


def _under(token: str, path: str) -> bool:
    return token == path or token.startswith(path.rstrip("/") + "/")


def _matches(key: str, command: DocCommand) -> bool:
    text = command.runnable
    return key == command.id or text == key or text.startswith(key + " ")


def _lookup(table: dict, command: DocCommand):
    keys = [k for k in table if _matches(k, command)]
    return table[max(keys, key=len)] if keys else None


def _until_stopped(command: DocCommand):
    if "--duration" in _tokens(command.runnable):
        return None
    return _lookup(UNTIL_STOPPED, command)


COMMANDS = find_commands()
RUNNABLE = [c for c in COMMANDS if c.runnable]


def _groups() -> tuple[list[list[DocCommand]], list[str]]:
    """Commands to run, in cases: a command joins the case of an earlier command of its block
    whose output it uses (of every such command: their cases become one). Also the problems: a run command that needs a not-run one."""
    groups, problems = [], []
    run = [c for c in RUNNABLE if _lookup(NOT_RUN, c) is None]
    skipped = [c for c in RUNNABLE if _lookup(NOT_RUN, c) is not None]
    for command in run:
        tokens = [t for t in _tokens(command.runnable) if not _is_operator(t)]

        def uses(earlier: DocCommand) -> bool:
            if earlier.block != command.block or earlier.file != command.file or earlier.line >= command.line:
                return False
            made = _outputs(earlier.runnable) + (earlier.shown[:1] if _until_stopped(earlier) else [])
            return any(_under(t, p) for t in tokens for p in made)

        for earlier in skipped:
            if uses(earlier):
                problems.append(f"{command.id} uses the output of {earlier.id}, which is in NOT_RUN")
        homes = [g for g in groups if any(uses(e) for e in g)]
        if not homes:
            groups.append([command])
        else:  # a command that uses the outputs of several cases joins them into one, in doc order
            home = homes[0]
            for other in homes[1:]:
                home.extend(other)
                groups.remove(other)
            home.sort(key=lambda c: c.line)
            home.append(command)
    return groups, problems


GROUPS, GROUP_PROBLEMS = _groups()


def test_the_docs_have_commands():
    assert any(c.file == "README.md" and c.runnable.startswith("tactile-bt run trees/cable_follow.yaml")
               for c in COMMANDS), "the quick start of README.md was not found: is the parser broken?"
    assert {c.file for c in COMMANDS} >= {"README.md", "docs/trees.md", "sim/README.md"}


def test_every_command_is_measured_or_not_run_with_a_reason():
    unlisted, both = [], []
    for c in RUNNABLE:
        measured, reason = _lookup(MEASURED_S, c), _lookup(NOT_RUN, c)
        if measured is None and not reason:
            unlisted.append(f"{c.id}: {c.runnable}")
        if measured is not None and reason:
            both.append(f"{c.id}: {c.runnable}")
    assert not unlisted, ("new doc commands: time each one by hand and add it to MEASURED_S, or add it "
                          "to NOT_RUN with the reason:\n" + "\n".join(unlisted))
    assert not both, "in MEASURED_S and NOT_RUN at once:\n" + "\n".join(both)
    assert not GROUP_PROBLEMS, "\n".join(GROUP_PROBLEMS)


def test_no_stale_entries():
    for table in (MEASURED_S, NOT_RUN, UNTIL_STOPPED):
        stale = [k for k in table if not any(_matches(k, c) for c in RUNNABLE)]
        assert not stale, f"no doc command matches: {stale}"


def test_the_commands_run_stay_within_the_budget():
    total = sum(_lookup(MEASURED_S, c) or 0.0 for g in GROUPS for c in g)
    assert total < BUDGET_S, f"{total:.0f} s of doc commands; move the slowest to NOT_RUN"


# --- pip install ------------------------------------------------------------------------------

PIP_COMMANDS = [c for c in COMMANDS if c.pip_segments]


@pytest.mark.parametrize("command", PIP_COMMANDS, ids=[c.id for c in PIP_COMMANDS])
def test_pip_install_names_this_package_and_existing_extras(command):
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    extras = set(project.get("optional-dependencies", {}))
    for segment in command.pip_segments:
        targets = [t for t in segment[2:] if not t.startswith("-")]
        assert targets, f"{command.id}: nothing to install in {shlex.join(segment)}"
        for target in targets:
            m = re.fullmatch(r"(\.)(?:\[([^\]]*)\])?", target)
            assert m, f"{command.id}: installs {target!r}, not this repository ('.' or '.[extra]')"
            wanted = {e.strip() for e in (m.group(2) or "").split(",") if e.strip()}
            assert wanted <= extras, f"{command.id}: extras {sorted(wanted - extras)} not in pyproject.toml {sorted(extras)}"


# --- running ----------------------------------------------------------------------------------

def _env() -> dict:
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    return env


def _wait_for_first_line(path: Path, process: subprocess.Popen, timeout: float) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        text = path.read_text(errors="replace") if path.exists() else ""
        if "\n" in text:
            return text.split("\n", 1)[0].strip()
        if process.poll() is not None:
            break
        time.sleep(0.05)
    return ""


def _stop(process: subprocess.Popen, sig: int) -> int:
    if process.poll() is None:
        process.send_signal(sig)
    try:
        return process.wait(timeout=15)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
        return -9


def _report(name: str, log_dir: Path) -> str:
    out = (log_dir / f"{name}.out").read_text(errors="replace")[-3000:]
    err = (log_dir / f"{name}.err").read_text(errors="replace")[-3000:]
    return f"\n--- stdout\n{out}\n--- stderr\n{err}"


@pytest.mark.slow
@pytest.mark.parametrize("group", GROUPS, ids=[g[0].id for g in GROUPS])
def test_doc_command_runs(group, tmp_path):
    env, logs = _env(), tmp_path / "logs"
    logs.mkdir()
    work = tmp_path / "work"
    work.mkdir()

    # every output of the case, and every later use of it, goes under tmp_path
    mapping = {}
    for command in group:
        for path in _outputs(command.runnable):
            mapping.setdefault(path, str(work / (Path(path).name if os.path.isabs(path) else path)))
    for name, source in PLACEHOLDER_FILES.items():
        if any(name in _tokens(c.runnable) for c in group):
            shutil.copy(REPO / source, work / name)
            mapping[name] = str(work / name)
    existed = {p: (REPO / p).exists() for p in mapping if not os.path.isabs(p)}

    def rewrite(token: str) -> str:
        if "=" in token and token.split("=", 1)[0] in OUTPUT_OPTIONS:
            option, value = token.split("=", 1)
            return f"{option}={rewrite(value)}"
        for original in sorted(mapping, key=len, reverse=True):
            if _under(token, original):
                return mapping[original] + token[len(original):]
        return token

    servers, files, failure = [], [], None  # servers: (command, process, signal, log name)
    try:
        for index, command in enumerate(group):
            tokens = [t if _is_operator(t) else rewrite(t) for t in _tokens(command.runnable)]
            name = f"{index}"
            files += [open(logs / f"{name}.out", "w"), open(logs / f"{name}.err", "w")]
            shell = any(_is_operator(t) for t in tokens)
            args = " ".join(t if _is_operator(t) else shlex.quote(t) for t in tokens) if shell else tokens
            process = subprocess.Popen(args, shell=shell, cwd=REPO, env=env, stdout=files[-2], stderr=files[-1],
                                       stdin=subprocess.DEVNULL, start_new_session=True)
            stopped = _until_stopped(command)
            if stopped is not None and stopped[0] is None:          # a server: keep it running
                servers.append((command, process, stopped[1], name))
                first = _wait_for_first_line(logs / f"{name}.out", process, timeout=30)
                assert first, f"{command.id}: printed nothing on stdout" + _report(name, logs)
                if command.shown:                                     # the doc's example, e.g. /dev/pts/7
                    mapping[command.shown[0]] = first
                continue
            if stopped is not None:
                time.sleep(stopped[0])
                code = _stop(process, stopped[1])
            else:
                try:
                    code = process.wait(timeout=TIMEOUT_S)
                except subprocess.TimeoutExpired:
                    os.killpg(process.pid, signal.SIGKILL)
                    process.wait()
                    pytest.fail(f"{command.id}: still running after {TIMEOUT_S} s" + _report(name, logs))
            errors = [line for line in command.shown if line.startswith("error:")]
            if errors:  # the doc shows an error on purpose
                assert code != 0, f"{command.id}: exit 0, the doc shows an error" + _report(name, logs)
                text = (logs / f"{name}.err").read_text(errors="replace")
                for line in errors:
                    assert line in text, f"{command.id}: the doc's {line!r} not printed" + _report(name, logs)
            else:
                assert code == 0, f"{command.id}: exit code {code}" + _report(name, logs)
    finally:
        for command, process, sig, name in reversed(servers):
            code = _stop(process, sig)
            if code != 0 and failure is None:
                failure = f"{command.id}: exit code {code} after {signal.Signals(sig).name}" + _report(name, logs)
        for f in files:
            f.close()
    assert failure is None, failure

    written = [p for p, before in existed.items() if not before and (REPO / p).exists()]
    assert not written, f"written into the repository: {written}"
