"""The package works where it is installed, not only in its checkout.

Builds the wheel of this checkout and of the example plugin (examples/plugin), installs both
into a fresh virtual environment (which reuses the installed dependencies of this one, so no
download is needed but the build backend), and runs from another folder: the studies' short
forms (``paper``, ``stability``, ``bench``), the README's main command, and a tree that uses the
plugin's leaf, found through its entry point.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.slow


def _run(cmd: list[str], cwd: Path, env: dict, timeout: float = 600) -> subprocess.CompletedProcess:
    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, f"{' '.join(map(str, cmd))} exited {done.returncode}:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(the fresh environment's bin folder, an empty working folder, its environment variables)."""
    base = tmp_path_factory.mktemp("installed")
    wheels = base / "wheels"
    source = base / "source"  # a copy: building writes build/ and *.egg-info/ into the tree it builds
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".git", "build", "dist", "out", "__pycache__",
                                                                "*.egg-info", ".pytest_cache", ".hypothesis"))
    for project in (source, source / "examples" / "plugin"):
        _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(wheels), str(project)],
             cwd=base, env=dict(os.environ))
    env_dir = base / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    purelib = Path(sysconfig.get_path("purelib", vars={"base": str(env_dir), "platbase": str(env_dir)}))
    # This environment's packages after the new one's own: the dependencies, never this checkout.
    outer = {sysconfig.get_path("purelib"), sysconfig.get_path("platlib")}
    (purelib / "outer.pth").write_text("\n".join(sorted(outer)) + "\n")
    bin_dir = env_dir / ("Scripts" if os.name == "nt" else "bin")
    python = bin_dir / "python"
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-deps", "--ignore-installed",
          *map(str, sorted(wheels.glob("*.whl")))], cwd=base, env=dict(os.environ))
    work = base / "elsewhere"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env["PATH"] = f"{bin_dir}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    located = _run([str(python), "-c", "import tactile_bt, tactile_bt_press; print(tactile_bt.__file__)"],
                   cwd=work, env=env).stdout.strip()
    assert Path(located).resolve().is_relative_to(env_dir.resolve()), located  # not the checkout
    return bin_dir, work, env


def test_the_studies_run_from_an_installed_package(installed):
    bin_dir, work, env = installed
    paper = _run([str(bin_dir / "tactile-bt"), "paper", "--trials", "1", "--workers", "1", "--out", "paper"],
                 cwd=work, env=env)
    assert "Table I" in paper.stdout and (work / "paper").is_dir()
    stability = _run([str(bin_dir / "tactile-bt"), "stability", "--no-rates", "--workers", "1", "--out", "stab"],
                     cwd=work, env=env)
    assert "✗" not in stability.stdout and "✓" in stability.stdout
    bench = _run([str(bin_dir / "tactile-bt"), "bench", "--quick", "--json"], cwd=work, env=env)
    assert json.loads(bench.stdout)


def test_the_readme_main_command_runs_from_another_folder(installed):
    bin_dir, work, env = installed
    run = _run([str(bin_dir / "tactile-bt"), "run", "trees/cable_follow.yaml", "--scene", "sim/cable.yaml",
                "--out", "out/cable"], cwd=work, env=env)
    assert run.stdout.startswith("success") and "ships with tactile_bt" in run.stderr
    _run([str(bin_dir / "tactile-bt"), "view", "out/cable", "--png", "out/cable/render.png"], cwd=work, env=env)
    for name in ("report.json", "log.npz", "errors.png", "contacts.ply", "render.png"):
        assert (work / "out" / "cable" / name).stat().st_size > 0, name


def test_an_installed_plugin_adds_its_leaf_to_trees(installed):
    bin_dir, work, env = installed
    tree = ROOT / "examples" / "plugin" / "press.yaml"
    shown = _run([str(bin_dir / "tactile-bt"), "tree", str(tree)], cwd=work, env=env)
    assert "press_until" in shown.stdout
    run = _run([str(bin_dir / "tactile-bt"), "run", str(tree), "--scene", "sim/pen.yaml", "--out", "press"],
               cwd=work, env=env)
    assert run.stdout.startswith("success")


def test_the_shipped_files_can_be_copied_and_used(installed):
    bin_dir, work, env = installed
    listed = _run([str(bin_dir / "tactile-bt"), "examples"], cwd=work, env=env)
    assert "sim/cable.yaml" in listed.stdout and "trees/cable_follow.yaml" in listed.stdout
    _run([str(bin_dir / "tactile-bt"), "examples", "--copy", "mine"], cwd=work, env=env)
    assert (work / "mine" / "sim" / "meshes" / "unknown_object.ply").is_file()
    shown = _run([str(bin_dir / "tactile-bt"), "tree", "mine/trees/scan_object.yaml"], cwd=work, env=env)
    assert "ships with" not in shown.stderr  # the copy, with its include, not the package's file
