"""Checkpoints and results files are checked whole before they are used.

A checkpoint's every draw (not only its last step), and the declared shape of every array of a
checkpoint or results file, are checked before a resume, ``summary``, ``report`` or ``compare``
reads them: a refusal is one line naming the file and what is wrong, exit 2, nothing written.
The files are made once per module (one short sampler run, one least-squares fit) and damaged
in copies through h5py, so that their checksums stay valid: what is caught is caught by the
checks, not by HDF5.
"""

from __future__ import annotations

import importlib
import shutil

import h5py
import numpy as np
import pytest

from .conftest import DATASETS
from .test_cli_safety import assert_refused, run
from .test_fuzz_inputs import memory_ceiling
from .test_resume_identity import _tamper as tamper  # datasets rewritten, checksums valid

RIG = DATASETS / "friction" / "monday1965_session_1095_steel.csv"
RIG_SCENE = DATASETS / "friction" / "monday1965_rig.toml"
FIT = ["fit", "data.csv", "--scene", "rig.toml", "--method", "emcee", "--walkers", "12", "--steps", "60",
       "--out", "r.h5"]
MU = 2  # friction.mu, bounded to [0, 1] by the scene; sampled in the problem's own coordinates


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A 60-step checkpoint (a run interrupted while writing its results), an emcee results file
    and a least-squares one, made once."""
    folder = tmp_path_factory.mktemp("made")
    shutil.copy(RIG, folder / "data.csv")
    shutil.copy(RIG_SCENE, folder / "rig.toml")
    fit_module = importlib.import_module("escfit.inference.fit")

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    with pytest.MonkeyPatch.context() as m:
        m.chdir(folder)
        m.setattr(fit_module, "write_fit", interrupt)
        assert run(*FIT).exit_code == 130
        m.undo()
        m.chdir(folder)
        assert run("fit", "data.csv", "--scene", "rig.toml", "--method", "emcee", "--walkers", "10", "--steps", "20",
                   "--out", "e.h5", "--quiet").exit_code == 0
        assert run("fit", "data.csv", "--scene", "rig.toml", "--out", "l.h5", "--quiet").exit_code == 0
    return folder


@pytest.fixture
def work(made, tmp_path, monkeypatch):
    for name in ("data.csv", "rig.toml", "r.h5.emcee", "e.h5", "l.h5"):
        shutil.copy(made / name, tmp_path / name)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def first_steps(value_fn, steps=slice(0, 1)):
    """A chain change applied to friction.mu of the given steps only (the last step untouched)."""
    def change(c):
        c = c.copy()
        c[steps, :, MU] = value_fn(c[steps, :, MU])
        return c
    return change


# -- every draw of a checkpoint, not only its last step ------------------------------------------

@pytest.mark.parametrize("changes, fragment", [
    ({"chain": first_steps(lambda mu: np.full_like(mu, 50.0))}, "step 1 of 60 stands outside the bounds of friction.mu"),
    ({"chain": first_steps(lambda mu: np.full_like(mu, np.nan), slice(10, 11))}, "not finite numbers"),
    ({"chain": first_steps(lambda mu: np.full_like(mu, np.inf), slice(30, 31))}, "not finite numbers"),
    # the whole posterior but its last step moved by 2 % (inside the bounds), log-probabilities kept,
    # the accepted counts raised so that the walkers' moves stay within them
    ({"chain": first_steps(lambda mu: mu * 1.02, slice(0, 59)), "accepted": lambda a: np.full_like(a, 60)},
     "belongs to another posterior: walker 0's stored log-probability at step 45 of 60"),
], ids=["draw-50-outside-0-1", "nan-draws", "inf-draws", "shifted-before-the-last-step"])
def test_every_draw_of_a_checkpoint_is_checked_before_resuming(work, changes, fragment):
    tamper(work / "r.h5.emcee", **changes)
    line = assert_refused(work, [*FIT, "--resume"], "r.h5.emcee", fragment)
    assert "--force" in line


def test_a_walker_that_stood_still_with_a_changed_log_probability_is_refused(work):
    """Between two steps a walker either moved or kept its log-probability: emcee never changes
    one without the other."""
    with h5py.File(work / "r.h5.emcee", "r") as f:
        chain = f["chain"][()]
    still = np.nonzero(np.all(chain[1:] == chain[:-1], axis=2))
    t, w = int(still[0][0]) + 1, int(still[1][0])

    def change(lp):
        lp = lp.copy()
        lp[t, w] -= 0.5
        return lp
    tamper(work / "r.h5.emcee", log_prob=change)
    assert_refused(work, [*FIT, "--resume"], "r.h5.emcee", f"walker {w}", f"step {t + 1}")


def test_more_moves_than_accepted_proposals_is_refused(work):
    tamper(work / "r.h5.emcee", accepted=lambda a: np.zeros_like(a))
    assert_refused(work, [*FIT, "--resume"], "r.h5.emcee", "accepted")


def test_an_untouched_checkpoint_still_resumes(work):
    r = run(*FIT, "--resume")
    assert r.exit_code == 0, r.output
    assert (work / "r.h5").is_file() and not (work / "r.h5.emcee").exists()


# -- declared layouts of checkpoints and results files, checked before reading -------------------

MEMORY_CEILING = 1024 << 20  # address space a refusal may add: reading a declared size would exceed it


def unwritten(name: str, shape, dtype="f8"):
    """Replace array ``name`` by one declaring ``shape`` whose chunks were never written."""
    def change(f):
        del f[name]
        f.create_dataset(name, shape=shape, dtype=dtype, chunks=tuple(min(n, 1 << 14) for n in shape))
    return change


def replaced(name: str, fn):
    def change(f):
        data = fn(f[name][()])
        del f[name]
        f.create_dataset(name, data=data)
    return change


def deleted(*names):
    def change(f):
        for name in names:
            del f[name]
    return change


def root_attr(key, value=None):
    def change(f):
        if value is None:
            del f.attrs[key]
        else:
            f.attrs[key] = value
    return change


def shorter_along_its_dimension(name: str):
    """``name`` cut to two values, still attached to its (longer) dimension."""
    def change(f):
        scale = f[f[name].dims[0][0].name]
        data = f[name][()][:2]
        del f[name]
        f.create_dataset(name, data=data)
        f[name].dims[0].attach_scale(scale)
    return change


def damage(path, change):
    with h5py.File(path, "r+") as f:
        change(f)


@pytest.mark.parametrize("change, fragments", [
    (unwritten("chain", (20_000_000, 12, 5)), ["array chain declares (20000000, 12, 5) values (9.6 GB)"]),
    (unwritten("log_prob", (60, 12_000_000)), ["array log_prob declares"]),
    (replaced("log_prob", lambda lp: lp[:, :6]), ["array log_prob has shape (60, 6), expected (60, 12)"]),
    (deleted("accepted"), ["its accepted array is missing"]),
    (replaced("mt_keys", lambda k: k.astype("f8")), ["mt_keys array holds 8-byte values"]),
    (root_attr("names"), ["format version 3"]),
], ids=["chain-of-9.6-gb-unwritten", "log-prob-declaring-144-mb", "log-prob-of-half-the-walkers", "no-accepted",
        "generator-key-of-doubles", "no-names"])
def test_a_checkpoint_with_a_missing_inconsistent_or_inflated_part_is_refused_before_reading(work, change,
                                                                                            fragments):
    damage(work / "r.h5.emcee", change)
    with memory_ceiling(MEMORY_CEILING):
        assert_refused(work, [*FIT, "--resume"], "r.h5.emcee", *fragments, "--force")


EMCEE, LSQ = "e.h5", "l.h5"
RESULTS_DAMAGE = [
    ("posterior-declaring-80-gb", EMCEE, unwritten("posterior/rig.k", (10, 1_000_000_000)),
     ["array posterior/rig.k declares (10, 1000000000) values (80 GB) but the file holds 0 bytes"]),
    ("lsq-values-declaring-8-gb", LSQ, unwritten("least_squares/value", (1_000_000_000,)),
     ["array least_squares/value declares"]),
    ("predictive-declaring-800-mb", EMCEE, unwritten("posterior_predictive/expected", (10, 10, 10_000_000)),
     ["posterior_predictive/expected"]),
    ("posterior-group-removed", EMCEE, deleted("posterior"), ["its posterior group is missing"]),
    ("diagnostics-group-removed", EMCEE, deleted("diagnostics"), ["its diagnostics group is missing"]),
    ("least-squares-group-removed", LSQ, deleted("least_squares"), ["its least_squares group is missing"]),
    ("a-parameter-removed", EMCEE, deleted("posterior/rig.k"), ["posterior/rig.k is missing"]),
    ("rhat-removed", EMCEE, deleted("diagnostics/rhat"), ["diagnostics/rhat is missing"]),
    ("values-shorter-than-their-dimension", LSQ, shorter_along_its_dimension("least_squares/value"),
     ["least_squares/value has 2 values along 'parameter', which has 5"]),
    ("values-without-a-dimension", LSQ, replaced("least_squares/stderr", lambda v: v),
     ["least_squares/stderr has no named dimension"]),
    ("parameters-attribute-removed", LSQ, root_attr("parameters"), ["'parameters' is missing"]),
    ("parameters-attribute-not-json", LSQ, root_attr("parameters", "[rig.k"), ["'parameters' is not a JSON list"]),
    ("units-attribute-a-list", LSQ, root_attr("units", "[1, 2]"), ["'units' is not a JSON object"]),
]


@pytest.mark.parametrize("file, change, fragments", [r[1:] for r in RESULTS_DAMAGE], ids=[r[0] for r in RESULTS_DAMAGE])
@pytest.mark.parametrize("command", ["summary", "report", "compare"])
def test_a_results_file_with_a_missing_inconsistent_or_inflated_part_is_refused_before_reading(
        work, command, file, change, fragments):
    shutil.copy(work / file, work / "whole.h5")  # the same fit undamaged, for compare
    damage(work / file, change)
    args = {"summary": ["summary", file], "report": ["report", file, "--format", "md"],
            "compare": ["compare", "whole.h5", file]}[command]
    with memory_ceiling(MEMORY_CEILING):
        assert_refused(work, args, file, *fragments)


def test_the_files_made_here_are_read_whole(work):
    """The checks refuse nothing escfit writes: both results files are summarised."""
    for args in (["summary", EMCEE], ["summary", LSQ]):
        r = run(*args)
        assert r.exit_code == 0, (args, r.output)


def test_a_file_given_twice_under_two_names_is_refused(work):
    (work / "link.h5").symlink_to("l.h5")
    assert_refused(work, ["compare", "l.h5", "./l.h5"], "the same results file is given twice (as 'l.h5' and './l.h5')")
    assert_refused(work, ["compare", "l.h5", "link.h5"], "link.h5: the same results file is given twice")


def test_a_refusal_of_a_results_file_is_one_line_without_third_party_warnings(work):
    """In a process of its own (the test runner would catch the warnings): a data array with no
    named dimension made xarray warn about 'phony_dims' on stderr before escfit's line."""
    import os
    import subprocess
    import sys

    from .conftest import ROOT

    damage(work / "l.h5", replaced("least_squares/stderr", lambda v: v))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("PYTHONWARNINGS", None)
    r = subprocess.run([sys.executable, "-c", "from escfit.cli.main import main; main()", "summary", "l.h5"],
                       capture_output=True, text=True, env=env, cwd=work, timeout=300)
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "l.h5" in r.stderr and "least_squares/stderr" in r.stderr


def test_declared_sizes_are_judged_by_what_the_file_holds(tmp_path):
    """The layout check itself: 2.4 MB of written values along a dimension without a coordinate
    pass (netCDF-4 leaves that dimension's 1.2 MB placeholder unwritten, and no reader reads it);
    the same values declared but never written are refused, naming the array."""
    import xarray as xr

    from escfit.core.errors import ResultsError
    from escfit.core.h5layout import check_backed, read_layout
    from escfit.core.h5write import write_netcdf

    path = tmp_path / "long.h5"
    write_netcdf(xr.Dataset({"x": (("obs",), np.arange(300_000.0))}), path)
    check_backed(read_layout(path))
    with h5py.File(path, "r+") as f:
        f.create_dataset("y", shape=(300_000,), dtype="f8", chunks=(1 << 14,))
    with pytest.raises(ResultsError, match=r"array y declares \(300000,\) values \(2.4 MB\) but the file holds 0 bytes"):
        check_backed(read_layout(path))
