"""docs/example.ipynb runs top to bottom (a run, a sweep, a diagnosis, the plots), in a real
Jupyter kernel, within a time limit."""

from __future__ import annotations

import os
from pathlib import Path

import nbformat
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]


def test_example_notebook_runs_top_to_bottom(tmp_path, monkeypatch):
    nb = nbformat.read(ROOT / "docs" / "example.ipynb", as_version=4)
    assert not any(c.get("outputs") for c in nb.cells if c.cell_type == "code"), "commit the notebook without outputs"
    # the kernel imports this tree's packages, whatever is installed; its figures come inline (PNG)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    monkeypatch.delenv("MPLBACKEND", raising=False)
    client = NotebookClient(nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}})
    client.execute()  # raises CellExecutionError, naming the cell, if any cell fails
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    text = " ".join(str(o.get("data", {}).get("text/plain", "")) for o in outputs)
    assert "'explained', 'vane_leakage'" in text  # the diagnosis names the hidden leak
    assert sum("image/png" in o.get("data", {}) for o in outputs) == 2  # the angles and the ranking
