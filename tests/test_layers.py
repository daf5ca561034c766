"""The house's arrows (README "Layout"): import-linter checks the contracts in pyproject.toml
([tool.importlinter]) on the whole source tree, so an import that runs back up a layer, a circle
between packages, MuJoCo in control/ or pneumatics/, or anything importing the shell fails here.
And its names: a class name means one thing across the shipped packages, and no class is named
like a package."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_every_package_keeps_to_its_layer():
    # import-linter's own entry point in a child: it reads pyproject.toml from, and puts on sys.path,
    # the working directory; no cache, so nothing is written into the tree
    code = "import sys; from importlinter.cli import lint_imports; sys.exit(lint_imports(no_cache=True, no_logo=True))"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "0 broken" in proc.stdout


def test_the_contracts_cover_every_shipped_package():
    shipped = set(PYPROJECT["tool"]["setuptools"]["packages"])
    linted = PYPROJECT["tool"]["importlinter"]
    assert set(linted["root_packages"]) == shipped
    (layers,) = (c for c in linted["contracts"] if c["type"] == "layers")
    in_layers = {name.strip() for layer in layers["layers"] for name in layer.split("|")}
    assert in_layers == shipped


def classes_of(packages) -> dict[str, list[str]]:
    """Every class defined in the packages' source (nested ones too), by name: where each is."""
    found: dict[str, list[str]] = {}
    for package in packages:
        for path in sorted((ROOT / package.replace(".", "/")).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
                if isinstance(node, ast.ClassDef):
                    found.setdefault(node.name, []).append(f"{path.relative_to(ROOT)}:{node.lineno}")
    return found


def test_a_class_name_means_one_thing():
    shipped = PYPROJECT["tool"]["setuptools"]["packages"]
    found = classes_of(shipped)
    assert len(found) > 100, "the search found too few classes to be looking at the source"
    twice = {name: where for name, where in found.items() if len(where) > 1}
    assert not twice, f"classes defined more than once (give each a name that says what it is): {twice}"
    named_like_a_package = {name: found[name] for name in found if name.lower() in {p.split(".")[-1] for p in shipped}}
    assert not named_like_a_package, f"classes named like a package: {named_like_a_package}"


def test_the_name_check_sees_a_second_definition(tmp_path, monkeypatch):
    # two packages each defining a `Row`, and one a class named like a package: both are found
    for package, source in (("one", "class Row:\n    pass\n"), ("two", "def f():\n    class Row: ...\n")):
        (tmp_path / package).mkdir()
        (tmp_path / package / "m.py").write_text(source)
    (tmp_path / "two" / "n.py").write_text("class One: ...\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    found = classes_of(["one", "two"])
    assert found["Row"] == ["one/m.py:1", "two/m.py:2"]
    assert found["One"] == ["two/n.py:1"]
