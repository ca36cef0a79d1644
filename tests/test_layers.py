"""The layer contract (pyproject ``[tool.importlinter]``): kept by the package, broken by
one upward import, and naming every module."""

from __future__ import annotations

import os
import pkgutil
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import grainfrac

ROOT = Path(__file__).resolve().parents[1]
SRC = Path(grainfrac.__file__).resolve().parent
# Packages with nothing but a docstring in their __init__: their modules are placed.
UNPLACED = {"grainfrac", "grainfrac.io"}


def _lint(config: Path, source_root: Path) -> subprocess.CompletedProcess:
    """lint-imports with ``source_root`` first on the path (no cache: a copy is new)."""
    env = {**os.environ, "PYTHONPATH": str(source_root)}
    code = ("import sys; from importlinter.cli import lint_imports; "
            f"sys.exit(lint_imports(config_filename={str(config)!r}, no_cache=True, "
            "no_logo=True))")
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, cwd=source_root)


def _layers() -> list[str]:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    (contract,) = config["tool"]["importlinter"]["contracts"]
    return contract["layers"]


def test_the_package_keeps_the_layer_contract():
    result = _lint(ROOT / "pyproject.toml", SRC.parent)
    print(result.stdout[-400:])
    assert result.returncode == 0, result.stdout + result.stderr
    assert "1 kept, 0 broken" in result.stdout


def test_an_upward_import_breaks_the_contract(tmp_path):
    """The same contract on a copy of the package in which the physics imports a figure
    module: lint-imports fails and names the import."""
    copy = tmp_path / "src"
    shutil.copytree(SRC, copy / "grainfrac", ignore=shutil.ignore_patterns("__pycache__"))
    kinematics = copy / "grainfrac" / "physics" / "kinematics.py"
    kinematics.write_text(kinematics.read_text() + "\nfrom grainfrac.viz import fields  # up\n")
    config = tmp_path / "pyproject.toml"
    shutil.copy(ROOT / "pyproject.toml", config)
    result = _lint(config, copy)
    print(result.stdout[-600:])
    assert result.returncode == 1, result.stdout + result.stderr
    assert "0 kept, 1 broken" in result.stdout
    assert "grainfrac.physics.kinematics -> grainfrac.viz.fields" in result.stdout


def test_every_module_is_in_a_layer():
    """A new top-level module must be given its layer (import-linter ignores unnamed ones)."""
    named = [m.strip() for layer in _layers() for m in layer.split(":")]
    modules = [info.name for info in pkgutil.walk_packages([str(SRC)], "grainfrac.")]
    unplaced = [m for m in modules if m not in UNPLACED
                and not any(m == n or m.startswith(n + ".") for n in named)]
    assert unplaced == []
