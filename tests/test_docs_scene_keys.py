"""The scene-key reference kept in the repository matches the scene readers (as the site build renders it)."""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
COMMITTED = ROOT / "docs" / "reference" / "_scene_keys.md"


@pytest.mark.slow  # reads every shipped scene and probes every key in a subprocess: 10-15 s of CPU
def test_committed_scene_key_tables_match_the_code(tmp_path):
    spec = importlib.util.spec_from_file_location("escfit_scenekeys", ROOT / "docs" / "_ext" / "escfit_scenekeys.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    text, renderer = module.render(ROOT, tmp_path / "cache.json")
    assert COMMITTED.is_file(), "docs/reference/_scene_keys.md is missing: run python docs/_ext/escfit_scenekeys.py"
    assert COMMITTED.read_text(encoding="utf-8") == text, (
        "docs/reference/_scene_keys.md is stale: run python docs/_ext/escfit_scenekeys.py and commit it")
    assert not renderer.stale_glossary()
    # the Markdown names the families' tables and real keys of the code
    for heading in ('model = "balance"', 'model = "geneva"', 'model = "verge"', 'model = "friction_rig"'):
        assert heading in text
    assert "`omega0`" in text and "`t_release`" in text


def test_scene_keys_page_points_at_the_tables_as_markdown():
    page = (ROOT / "docs" / "reference" / "scene-keys.md").read_text(encoding="utf-8")
    assert "`docs/reference/_scene_keys.md`" in page and "{include} _scene_keys.md" in page
    assert COMMITTED.is_file() and COMMITTED.stat().st_size > 10_000
