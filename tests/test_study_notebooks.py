"""The study notebooks (jupytext percent scripts) execute from top to bottom.

The default run is the smoke path: the same small settings as ``test_study_fits`` and the same
results directory, so units fitted there are not fitted again.  The full-size run (20 units
per fleet, longer chains) is marked slow.
"""

from __future__ import annotations

import pytest

from .conftest import ROOT

NOTEBOOKS = ROOT / "notebooks"
ORDER = ("01_fleet_fits.py", "02_population.py", "03_model_comparison.py")
FIGURES = ("fleet_recordings.png", "unit_estimates.png", "population.png", "shrinkage_C.png", "scatter_vs_noise.png",
           "loo.png", "chapter5.png")


def _needs_study_extra() -> None:
    for module in ("jupytext", "nbclient", "ipykernel", "distributed"):
        pytest.importorskip(module, reason="the notebooks need the 'study' extra (pip install -e '.[study]')")


def _execute(env: dict[str, str], monkeypatch) -> None:
    _needs_study_extra()
    import jupytext
    from nbclient import NotebookClient

    for key, value in env.items():
        monkeypatch.setenv(key, value)  # the kernel inherits this process's environment
    for name in ORDER:
        nb = jupytext.read(NOTEBOOKS / name)
        NotebookClient(nb, timeout=1800, kernel_name="python3",
                       resources={"metadata": {"path": str(NOTEBOOKS)}}).execute()
        errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
                  if o.get("output_type") == "error"]
        assert not errors, (name, errors)


def test_notebooks_are_percent_scripts():
    jupytext = pytest.importorskip("jupytext")

    for name in ORDER:
        text = (NOTEBOOKS / name).read_text()
        assert "format_name: percent" in text and "# %% [markdown]" in text
        nb = jupytext.reads(text, fmt="py:percent")
        assert sum(c.cell_type == "code" for c in nb.cells) >= 4


@pytest.mark.slow  # runs every notebook end to end on small fleets (about a minute): CI's slow step
def test_notebooks_smoke(tmp_path, tmp_path_factory, monkeypatch):
    from .test_study_fits import CHAPTER5_UNITS, CROSS_UNITS, STEPS, WALKERS, study_dir

    figures = tmp_path / "figures"
    _execute({"ESCFIT_STUDY_WORK": str(study_dir(tmp_path_factory)), "ESCFIT_STUDY_FIGURES": str(figures),
              "ESCFIT_STUDY_UNITS": "20", "ESCFIT_STUDY_CHAPTER5_UNITS": str(CHAPTER5_UNITS),
              "ESCFIT_STUDY_CROSS_UNITS": str(CROSS_UNITS), "ESCFIT_STUDY_WALKERS": str(WALKERS),
              "ESCFIT_STUDY_STEPS": str(STEPS), "ESCFIT_STUDY_POPULATION_STEPS": "500", "ESCFIT_STUDY_WORKERS": "2"},
             monkeypatch)
    for f in FIGURES:
        assert (figures / f).stat().st_size > 10_000, f


@pytest.mark.slow
def test_notebooks_full_size(tmp_path, monkeypatch):
    figures = tmp_path / "figures"
    _execute({"ESCFIT_STUDY_WORK": str(tmp_path / "work"), "ESCFIT_STUDY_FIGURES": str(figures),
              "ESCFIT_STUDY_WORKERS": "2"}, monkeypatch)
    for f in FIGURES:
        assert (figures / f).stat().st_size > 10_000, f
