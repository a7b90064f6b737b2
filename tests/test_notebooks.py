"""The notebooks run top to bottom (small configuration: PDW_NOTEBOOK_SMALL=1); their own
cells assert the physics (fixed point converged, period doubling between 4 and 5 deg, a
Neimark-Sacker point on the 6-link branch) and every figure is displayed."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
#: notebook 02 also shows the fitted gait as OpenSim sees it when OpenSim is installed
OPENSIM = importlib.util.find_spec("opensim") is not None


@pytest.mark.parametrize("name, images", [("01_reproduce_paper.ipynb", 2),
                                          ("02_fit_your_gait.ipynb", 2 if OPENSIM else 1),
                                          ("03_slope_sweep.ipynb", 3),
                                          ("04_humanlike_timing.ipynb", 1),
                                          ("06_cohort.ipynb", 2),
                                          # a stride NLP design (IPOPT) and a subject
                                          # continuation: about 2 min, so in the slow run
                                          pytest.param("05_prosthesis_design.ipynb", 1,
                                                       marks=pytest.mark.slow)])
def test_notebook_runs(name, images, tmp_path, monkeypatch):
    monkeypatch.setenv("PDW_NOTEBOOK_SMALL", "1")
    monkeypatch.setenv("PDW_NOTEBOOK_OUT", str(tmp_path))
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    NotebookClient(nb, timeout=600, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"]
    shown = [o for o in outputs if o.output_type == "display_data"
             and ({"image/png", "image/gif"} & set(o.get("data", {})))]
    assert len(shown) >= images
    assert all(p.stat().st_size > 0 for p in tmp_path.glob("*.png"))
