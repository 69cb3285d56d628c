"""Shared fixtures: scene builders and paths."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

ROOT = Path(__file__).resolve().parents[1]
DATASETS = ROOT / "datasets"

def _shared() -> Path:
    """The shared source folder (``../shared`` of the checkout, or of the folder holding worktrees;
    ``ESCFIT_SHARED`` overrides)."""
    if os.environ.get("ESCFIT_SHARED"):
        return Path(os.environ["ESCFIT_SHARED"])
    for base in (ROOT.parent, ROOT.parent.parent):
        if (base / "shared").is_dir():
            return base / "shared"
    return ROOT.parent / "shared"


SHARED = _shared()

settings.register_profile("escfit", derandomize=True, deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "escfit"))


def balance_toml(*, omega0=10.0, theta0=1.0, swings=20, switching="angle", effects="") -> str:
    """A minimal balance scene as TOML text."""
    return (
        f'model = "balance"\nswitching = "{switching}"\n[oscillator]\nomega0 = {omega0!r}\ntheta0 = {theta0!r}\n'
        f"[run]\nswings = {swings}\n{effects}"
    )


@pytest.fixture
def make_scene():
    from escfit import load_scene

    def make(**kw):
        return load_scene("test.toml", text=balance_toml(**kw))

    return make
