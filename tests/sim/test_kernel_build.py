"""The first run's kernel build on two cores (tactile_bt.sim.warmup)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tactile_bt import run_mission
from tactile_bt.sim import warmup

ROOT = Path(__file__).resolve().parents[2]
TREE = ROOT / "trees" / "cable_follow.yaml"
SCENE = ROOT / "sim" / "cable.yaml"


def _empty_cache_env(cache: Path) -> dict:
    """The environment of a fresh process on this checkout with the kernel cache ``cache``."""
    return dict(os.environ, NUMBA_CACHE_DIR=str(cache),
                PYTHONPATH=os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p))


_CHECK = """
import sys
from tactile_bt import run_mission
from tactile_bt.sim import warmup
run_mission(sys.argv[1], sys.argv[2], duration=0.05)
for group in warmup.GROUPS:
    for dispatcher, signature in warmup._signatures(group):
        name = dispatcher.py_func.__name__
        extra = [s for s in dispatcher.signatures if tuple(s) != tuple(signature)]
        if extra:
            sys.exit(f"{group}: the mission compiled {name}{extra[0]} as well")
"""


@pytest.mark.slow
def test_the_build_ahead_compiles_exactly_what_a_mission_calls(tmp_path):
    """A mission on an empty cache compiles no other version of a function built ahead (a wrong
    signature would be built for nothing, and the right one compiled late, in series)."""
    env = _empty_cache_env(tmp_path / "cache")
    done = subprocess.run([sys.executable, "-c", _CHECK, str(TREE), str(SCENE)], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr


def test_a_warm_cache_keeps_no_second_process_and_later_missions_check_nothing():
    run_mission(TREE, SCENE, duration=0.05)
    warmup.start()
    assert warmup._build is None and warmup._built
    warmup.finish()  # nothing to wait for


def test_the_second_process_builds_the_running_package_not_one_in_the_working_directory(tmp_path):
    """numba caches per source file: a build of another copy of tactile_bt (say, a clone in the
    working directory of an installed one) would leave this one's cache empty."""
    decoy = tmp_path / "tactile_bt"
    decoy.mkdir()
    (decoy / "__init__.py").write_text("raise ImportError('the copy in the working directory')\n")
    done = subprocess.run(warmup._command("arm"), cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr


def test_an_unknown_group_is_named():
    with pytest.raises(ValueError, match="unknown kernel group 'elbow'"):
        warmup.compile_group("elbow")


@pytest.mark.slow
def test_a_first_run_on_an_empty_cache_builds_on_two_processes_and_gives_the_same_run(tmp_path):
    """The cold path end to end: a fresh process with an empty kernel cache runs the mission
    (the second process fills the cache as it goes), and a warm run of it gives the same report."""
    env = _empty_cache_env(tmp_path / "cache")
    outputs = []  # (rc 1: a mission this short ends on its budget, not by touch)
    for run in ("cold", "warm"):
        out = tmp_path / run
        done = subprocess.run([sys.executable, "-m", "tactile_bt.cli", "run", str(TREE), "--scene", str(SCENE),
                               "--duration", "2", "--out", str(out)], env=env, capture_output=True, text=True,
                              timeout=600)
        assert done.returncode in (0, 1) and "Traceback" not in done.stderr, done.stderr
        lines = done.stdout.splitlines()
        outputs.append((done.returncode, lines[0].split(" (")[0], lines[1:-1]))  # no wall-clock factor, no path
    assert outputs[0] == outputs[1]
    cached = {p.name.split("-")[0] for p in (tmp_path / "cache").rglob("*.nbi")}
    assert {"kernels.arm_step", "kernels.largest_region", "kernels.pad_contact", "kernels.raw_counts"} <= cached


def _fake_build(monkeypatch, child: str) -> list:
    """A build whose second process runs ``child`` (Python source), with this process's
    compiles recorded instead of done; returns the record."""
    built = []
    monkeypatch.setattr(warmup, "_command", lambda *groups: [sys.executable, "-c", child])
    monkeypatch.setattr(warmup, "compile_group", built.append)
    monkeypatch.setattr(warmup, "TIMEOUT_S", 60.0)
    monkeypatch.setattr(warmup, "_built", False)
    build = warmup._Build()
    build.give()
    monkeypatch.setattr(warmup, "_build", build)
    return built


def test_a_group_the_second_process_dies_on_is_built_here(monkeypatch):
    built = _fake_build(monkeypatch, "import sys; sys.stdin.readline(); sys.exit(3)")
    warmup.finish()
    assert sorted(built) == sorted(warmup.GROUPS)
    assert warmup._built and warmup._build is None


def test_a_second_process_that_reports_nonsense_does_not_stall_the_run(monkeypatch):
    """Lines that name no group still hand out the next one, and what was never reported is
    built here."""
    child = "import sys\nfor line in sys.stdin:\n    print('noise ' + line.strip(), flush=True)\n"
    built = _fake_build(monkeypatch, child)
    warmup.finish()
    assert sorted(built) == sorted(warmup.GROUPS)


def test_groups_the_second_process_reports_are_not_built_again(monkeypatch):
    child = "import sys\nfor line in sys.stdin:\n    print(line.strip(), flush=True)\n"
    built = _fake_build(monkeypatch, child)
    warmup.finish()
    assert len(built) == len(set(built)) < len(warmup.GROUPS)  # the second process took at least one


def test_one_core_and_a_cold_cache_compile_in_finish_and_say_so_before(monkeypatch):
    """No second process on one core: start() notes the cold cache (so that the progress says it
    compiles) and finish() builds every group here, before the mission's clock starts."""
    built = []
    monkeypatch.setattr(warmup, "_cores", lambda: 1)
    monkeypatch.setattr(warmup, "_all_cached", lambda: False)
    monkeypatch.setattr(warmup, "compile_group", built.append)
    monkeypatch.setattr(warmup, "_built", False)
    monkeypatch.setattr(warmup, "_cold_here", False)
    warmup.start()
    assert warmup.compiling() and warmup._build is None
    warmup.finish()
    assert built == list(warmup.GROUPS) and not warmup.compiling() and warmup._built
