"""The house's arrows (README "Layout"): import-linter checks the contracts in pyproject.toml
([tool.importlinter]) on the whole source tree, so an import that runs back up a layer, a circle
between packages, MuJoCo in control/ or pneumatics/, or anything importing the shell fails here."""

from __future__ import annotations

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
