"""The package a team adopts: its licence file and SPDX expression, typed packages, `python -m
twin_cli`, a bound on the 0.x dependency that breaks between minors, and libraries that log
instead of printing (the command line prints; --verbose shows the libraries' log)."""

from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

from packaging.requirements import Requirement
from packaging.version import Version

from twin_cli.cli import main as twin_main

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_licence_file_is_the_apache_2_text_the_metadata_names():
    project = PYPROJECT["project"]
    assert project["license"] == "Apache-2.0" and project["license-files"] == ["LICENSE"]
    text = (ROOT / "LICENSE").read_text()
    assert "Apache License" in text and "Version 2.0, January 2004" in text
    assert "END OF TERMS AND CONDITIONS" in text and text.count("\n") > 190  # the whole text, not a notice
    assert not any(c.startswith("License ::") for c in project["classifiers"])  # PEP 639: the expression says it


def test_every_package_is_typed_and_ships_its_marker():
    packages = PYPROJECT["tool"]["setuptools"]["packages"]
    data = PYPROJECT["tool"]["setuptools"]["package-data"]
    for p in packages:
        assert (ROOT / p / "py.typed").is_file(), p
        assert "py.typed" in data.get(p, []) + data.get("*", []), p


def test_rerun_sdk_is_bounded_above_and_the_installed_one_is_inside():
    (rerun,) = [Requirement(r) for r in PYPROJECT["project"]["dependencies"] if r.startswith("rerun-sdk")]
    installed = Version(metadata.version("rerun-sdk"))
    assert installed in rerun.specifier
    upper = [s for s in rerun.specifier if s.operator == "<"]
    assert upper and Version(f"{installed.major}.{installed.minor + 1}") not in rerun.specifier


def test_python_m_twin_cli_is_the_twin_command():
    out = subprocess.run(
        [sys.executable, "-m", "twin_cli", "--help"], capture_output=True, text=True, cwd=ROOT, timeout=60
    )
    assert out.returncode == 0 and "usage: twin" in out.stdout and "--verbose" in out.stdout


def _prints_outside_main(path: Path) -> list[int]:
    """Lines of `print(...)` calls in a module, except in its program (`python -m module`): under
    `if __name__ == "__main__":` or in the `main()` that block calls."""
    tree = ast.parse(path.read_text())
    skip: set[int] = set()
    for node in ast.walk(tree):
        program = isinstance(node, ast.If) and "__main__" in ast.unparse(node.test)
        if program or (isinstance(node, ast.FunctionDef) and node.name == "main"):
            skip |= {n.lineno for n in ast.walk(node) if hasattr(n, "lineno")}
    return [
        n.lineno
        for n in ast.walk(tree)
        if isinstance(n, ast.Call) and getattr(n.func, "id", None) == "print" and n.lineno not in skip
    ]


def test_library_modules_log_rather_than_print():
    """Only the command line (twin_cli) and the benchmarks' reports print; the libraries log."""
    found = {}
    for package in ("twin_plumbing", "pneumatics", "control", "twin", "scenarios", "gap", "pneumatic_arm_twin"):
        for path in sorted((ROOT / package).rglob("*.py")):
            lines = _prints_outside_main(path)
            if lines:
                found[str(path.relative_to(ROOT))] = lines
    assert found == {}


def test_verbose_shows_what_the_libraries_log(capsys):
    # a 0.1 s run judges none of its criteria: NOT JUDGED, exit 1 (README, "Reliability")
    assert twin_main(["run", "wrist_closed_loop_60deg", "--duration", "0.1"]) == 1
    assert "s simulated, seed" not in capsys.readouterr().err
    assert twin_main(["--verbose", "run", "wrist_closed_loop_60deg", "--duration", "0.1"]) == 1
    assert "twin: wrist_closed_loop_60deg: 0.1 s simulated, seed" in capsys.readouterr().err
    twin_main(["run", "wrist_closed_loop_60deg", "--duration", "0.1"])  # back to warnings only


def test_every_data_file_inside_a_package_ships_with_it():
    # a file the code reads beside its modules (a scenario, a joint file, an arm protocol) must be in
    # the wheel too, or an installed twin cannot find it
    packages = PYPROJECT["tool"]["setuptools"]["packages"]
    data = PYPROJECT["tool"]["setuptools"]["package-data"]
    left_out = []
    for p in packages:
        globs = data.get(p, []) + data.get("*", [])
        for f in (ROOT / p).rglob("*"):
            rel = f.relative_to(ROOT / p)
            if f.is_dir() or f.suffix in (".py", ".pyc") or "__pycache__" in rel.parts:
                continue
            if not any(rel.match(g) and len(rel.parts) == len(Path(g).parts) for g in globs):
                left_out.append(f"{p}/{rel}")
    assert not left_out, left_out
