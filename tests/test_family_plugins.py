"""A model family an installed package declares by entry point (escfit.core.family.ENTRY_POINT_GROUP).

The toy family of ``tests/toy_family.py`` is declared here the way a package declares it: a
``*.dist-info`` folder with an ``entry_points.txt`` on the path of a fresh process that never
calls :func:`~escfit.core.family.register_family`.  That process, and the dask worker processes
``escfit fit-many`` starts, must find the family by its ``model =`` name and fit the toy's
example to its truth.  A declared family whose module cannot be imported is refused in one
line naming the entry point, and a run of the shipped families never reads the entry points.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from escfit.core import family as registry

from . import toy_family

ROOT = Path(__file__).resolve().parents[1]


def _declare(folder: Path, entries: dict[str, str]) -> Path:
    """A site folder holding one installed distribution that declares ``entries`` (name -> module:attr)."""
    info = folder / "escfit_toy_plugin-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: escfit-toy-plugin\nVersion: 1.0\n")
    lines = [f"[{registry.ENTRY_POINT_GROUP}]"] + [f"{k} = {v}" for k, v in entries.items()]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")
    return folder


def _escfit(site: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(ROOT)])}
    return subprocess.run([sys.executable, "-m", "escfit", *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=300)


def test_a_declared_family_fits_in_a_fresh_process(tmp_path):
    site = _declare(tmp_path / "site", {toy_family.NAME: "tests.toy_family:FAMILY"})
    scene, data = toy_family.example(tmp_path)
    r = _escfit(site, "fit", str(data), "--scene", str(scene), "--out", "r.h5", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr + r.stdout
    r = _escfit(site, "summary", "r.h5", "--json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)["parameters"]
    for name in ("toy.omega", "toy.gamma"):
        assert abs(rows[name]["estimate"] - toy_family.TRUTH[name]) <= 4 * rows[name]["stderr"], rows[name]


@pytest.mark.slow  # starts a dask cluster of one worker process
def test_dask_workers_find_a_declared_family(tmp_path):
    site = _declare(tmp_path / "site", {toy_family.NAME: "tests.toy_family:FAMILY"})
    scene, data = toy_family.example(tmp_path)
    r = _escfit(site, "fit-many", str(data), "--scene", str(scene), "--out", "fleet", "--workers", "1", "--quiet",
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr + r.stdout
    r = _escfit(site, "summary", "fleet", "--json", cwd=tmp_path)
    assert [u["status"] for u in json.loads(r.stdout)["units"]] == ["ok"]


def test_a_declared_family_that_cannot_be_imported_is_one_line(tmp_path):
    site = _declare(tmp_path / "site", {"broken_family": "no_such_module_anywhere:FAMILY"})
    scene = tmp_path / "broken.toml"
    scene.write_text('model = "broken_family"\n')
    r = _escfit(site, "simulate", str(scene), "--out", "s.h5", cwd=tmp_path)
    assert r.returncode == 2, r.stderr + r.stdout
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "no_such_module_anywhere:FAMILY" in lines[0] and registry.ENTRY_POINT_GROUP in lines[0]
    assert not (tmp_path / "s.h5").exists()


def test_the_shipped_families_never_read_the_entry_points(monkeypatch):
    import importlib.metadata

    def refuse(*args, **kwargs):
        raise AssertionError("entry points read for a shipped family")

    monkeypatch.setattr(importlib.metadata, "entry_points", refuse)
    monkeypatch.setattr(registry, "_SCANNED", False)
    assert registry.get_family("balance").name == "balance"
    assert registry.get_family("verge").name == "verge"


def test_a_declared_family_comes_back_after_unregistering(monkeypatch):
    """An entry point with extras names its module and attribute only; unregistering a declared
    family that was replaced in the process brings the declared one back, as for a built-in."""
    import importlib.metadata

    ep = importlib.metadata.EntryPoint(name="toy_declared", value="tests.toy_family:FAMILY [fast]",
                                       group=registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group=None: [ep])
    monkeypatch.setattr(registry, "_SCANNED", False)
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    monkeypatch.setattr(registry, "_FROM_ENTRY_POINTS", {})
    assert registry.get_family("toy_declared") is toy_family.FAMILY
    registry.register_family(toy_family.FAMILY, "toy_declared", replace=True)
    registry.unregister_family("toy_declared")
    assert "toy_declared" in registry.family_names()
    assert registry.get_family("toy_declared") is toy_family.FAMILY
