"""The kernels' import scan, kept between processes by the files' contents.

A kept result must be the parse of the file as it is now: an edit is parsed again, a second
process parses nothing it has seen, and the kernels' source closures are those of a fresh parse.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import escfit
from escfit.core import import_scan, kernels


def test_an_edited_file_is_parsed_again(tmp_path):
    mod = tmp_path / "pkg" / "mod.py"
    mod.parent.mkdir()
    mod.write_text("from . import a\nimport os\n")
    first = import_scan.import_requests(mod, "pkg.mod")
    assert sorted(first, key=str) == [["os", None], ["pkg.a", "pkg"]]
    mod.write_text("from .b import c\ndef f():\n    from .. import x\n")  # beyond the package: dropped
    second = import_scan.import_requests(mod, "pkg.mod")
    assert sorted(second) == [["pkg.b.c", "pkg.b"]]
    mod.write_text("from . import a\nimport os\n")  # back to the first content
    assert import_scan.import_requests(mod, "pkg.mod") == first


def test_kernel_closures_are_those_of_a_fresh_parse():
    root = Path(escfit.__file__).resolve().parents[1]
    exact = Path(escfit.__file__).resolve().parent / "balance" / "exact.py"
    kept = kernels._import_closure(exact, "escfit.balance.exact")
    for path in kept:
        rel = path.relative_to(root).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        assert import_scan.import_requests(path, name) == import_scan._parse(path.read_bytes(), path, name)
    assert any(p.name == "segment.py" for p in kept) and any(p.name == "walker.py" for p in kept)


def test_a_second_process_parses_nothing_it_has_seen(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    first = "import escfit.balance.exact"
    subprocess.run([sys.executable, "-c", first], env=env, check=True)
    assert (tmp_path / import_scan.FILE_NAME).is_file()
    second = ("import escfit.core.import_scan as s\n"
              "def refuse(*a):\n    raise SystemExit('parsed again')\n"
              "s._parse = refuse\n"
              "import escfit.balance.exact\n")
    out = subprocess.run([sys.executable, "-c", second], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-500:]
