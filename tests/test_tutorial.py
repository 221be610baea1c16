"""The tutorial notebook (docs/tutorial/tutorial.ipynb) runs as it is, top to bottom, in a
real Jupyter kernel (nbclient), and shows what its text says it shows."""

from __future__ import annotations

import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NOTEBOOK = os.path.join(ROOT, "docs", "tutorial", "tutorial.ipynb")


@pytest.mark.slow  # a kernel, a measured point, a reference and a two-point sweep: about 15-30 s on 2 cores
def test_the_tutorial_runs_and_shows_the_decomposition_a_frame_and_a_sweep(cache, tmp_path):
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    assert not any(cell.get("outputs") for cell in nb.cells if cell.cell_type == "code")  # stored without outputs
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for cell in nb.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    text = "\n".join(str(o.get("text", "")) + str(o.get("data", {}).get("text/plain", "")) for o in outputs)
    assert "one frame's relative MSE" in text and "kernel_blur" in text and "residual" in text
    assert "2 points measured, 0 read back" in text
    assert any("image/png" in o.get("data", {}) for o in outputs)  # the frame beside the reference
