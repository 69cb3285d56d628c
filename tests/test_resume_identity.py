"""A checkpoint resumes only the run it belongs to; signals save; one run per results file.

Each refusal exits 2 with one line naming the checkpoint and what differs, and leaves the folder
as it was (the checkpoint included): the way on (``--force``, or the same inputs) stays open.
The reference for a resume that is allowed is an uninterrupted run with the same seed, whose
draws it must reproduce bit for bit (one environment, one run: no comparison across versions).
"""

from __future__ import annotations

import importlib
import os
import shutil
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

from escfit.core.outlock import output_lock

from .conftest import DATASETS, ROOT
from .test_cli_safety import assert_refused, listing, run

FIT = ["fit", "data.csv", "--scene", "rig.toml", "--method", "emcee", "--walkers", "12", "--steps", "60",
       "--out", "r.h5"]


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copy(DATASETS / "friction" / "monday1965_session_1095_steel.csv", tmp_path / "data.csv")
    shutil.copy(DATASETS / "friction" / "monday1965_rig.toml", tmp_path / "rig.toml")
    return tmp_path


@pytest.fixture
def interrupted(work, monkeypatch):
    """A complete 60-step checkpoint, as a run interrupted while writing its results leaves it."""
    fit_module = importlib.import_module("escfit.inference.fit")

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    with monkeypatch.context() as m:
        m.setattr(fit_module, "write_fit", interrupt)
        r = run(*FIT)
    assert r.exit_code == 130, r.output
    assert "60 sampler steps are saved in r.h5.emcee" in r.stderr
    assert sorted(p.name for p in work.iterdir()) == ["data.csv", "r.h5.emcee", "rig.toml"]  # no lock left
    return work


def _posterior(path) -> np.ndarray:
    with h5py.File(path, "r") as f:
        return np.stack([f["posterior"][k][()] for k in ("rig.k", "friction.mu")])


def test_the_same_run_resumes_to_the_uninterrupted_draws(interrupted, tmp_path_factory):
    r = run(*FIT, "--resume")
    assert r.exit_code == 0, r.output
    other = tmp_path_factory.mktemp("whole")
    for name in ("data.csv", "rig.toml"):
        shutil.copy(interrupted / name, other / name)
    os.chdir(other)
    assert run(*FIT).exit_code == 0
    np.testing.assert_array_equal(_posterior(interrupted / "r.h5"), _posterior(other / "r.h5"))


def _change_a_reading(path):
    lines = path.read_text().splitlines()
    i = next(k for k, line in enumerate(lines) if line[:1].isdigit())
    cells = lines[i].split(",")
    j = next(k for k in range(len(cells) - 1, -1, -1) if cells[k].replace(".", "").isdigit())
    cells[j] = repr(float(cells[j]) + 4)
    lines[i] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("change, extra, fragment", [
    (lambda w: _change_a_reading(w / "data.csv"), [], "its data SHA-256 is"),
    (lambda w: (w / "rig.toml").write_text((w / "rig.toml").read_text().replace("value = 0.12", "value = 0.13")),
     [], "its scene text (SHA-256) is"),
    (lambda w: None, ["--seed", "3"], "its seed is '0', this run's is '3'"),
    (lambda w: None, ["--moves", "de"], "moves 'stretch'"),
    (lambda w: None, ["--walkers", "14"], "checkpoint holds 12 walkers x 5 parameters"),
])
def test_a_checkpoint_of_another_run_is_refused(interrupted, change, extra, fragment):
    change(interrupted)
    line = assert_refused(interrupted, [*FIT, "--resume", *extra], "r.h5.emcee", fragment)
    assert "--force" in line


def test_resume_with_least_squares_is_refused_not_ignored(interrupted):
    assert_refused(interrupted, ["fit", "data.csv", "--scene", "rig.toml", "--out", "q.h5", "--resume"],
                   "--resume continues an interrupted emcee run")


def _tamper(path, **changes):
    """Rewrite datasets of a checkpoint through h5py: the checksums stay valid."""
    with h5py.File(path, "r+") as f:
        for name, fn in changes.items():
            data = fn(f[name][()])
            del f[name]
            f.create_dataset(name, data=data, fletcher32=True)


@pytest.mark.parametrize("changes, fragment", [
    ({"chain": lambda c: np.where(np.arange(c.shape[-1]) == 2, -50.0, c)}, "outside the bounds of friction.mu"),
    ({"chain": lambda c: np.where(np.arange(c.shape[-1]) == 2, np.nan, c)}, "not finite numbers"),
    ({"log_prob": lambda lp: lp + 1.0}, "belongs to another posterior"),
    ({"accepted": lambda a: a + 10**6}, "accepted-proposal counts"),
])
def test_a_tampered_checkpoint_with_valid_checksums_is_refused(interrupted, changes, fragment):
    _tamper(interrupted / "r.h5.emcee", **changes)
    assert_refused(interrupted, [*FIT, "--resume"], "r.h5.emcee", fragment)


def test_an_all_zero_generator_state_is_refused_not_hung(interrupted):
    """numpy would loop for ever on an all-zero MT19937 state, deaf to signals: a subprocess with
    a time limit, so that a regression fails instead of hanging the suite."""
    _tamper(interrupted / "r.h5.emcee", mt_keys=lambda k: np.zeros_like(k))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, "-c", "from escfit.cli.main import main; main()", *FIT, "--resume"], capture_output=True, text=True,
                       timeout=120, env=env, cwd=interrupted)
    assert r.returncode == 2, r.stderr
    assert "random-generator state" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_two_runs_of_one_results_file_one_is_refused(interrupted):
    with output_lock(interrupted / "r.h5"):  # another run holds the results file
        before = listing(interrupted)
        r = run(*FIT, "--resume")
        assert r.exit_code == 2 and "another escfit run (pid" in r.stderr, r.output
        assert listing(interrupted) == before
    assert run(*FIT, "--resume").exit_code == 0  # the checkpoint is still there to resume


@pytest.mark.parametrize("sig", ["SIGHUP", "SIGQUIT", "SIGTERM"])
def test_a_signal_during_least_squares_ends_the_command_and_writes_nothing(work, monkeypatch, sig):
    fit_module = importlib.import_module("escfit.inference.fit")

    real = fit_module.least_squares

    def signalled(*args, **kwargs):
        os.kill(os.getpid(), getattr(signal, sig))
        return real(*args, **kwargs)

    monkeypatch.setattr(fit_module, "least_squares", signalled)
    before = listing(work)
    r = run(*FIT)
    assert r.exit_code == 130, r.output
    assert listing(work) == before


@pytest.mark.parametrize("sig", ["SIGHUP", "SIGTERM"])
def test_a_signal_while_writing_the_report_keeps_the_results_and_says_how_to_finish(work, monkeypatch, sig):
    import escfit.report as report

    monkeypatch.setattr(report, "fit_statistics", _signalling(report.fit_statistics, sig))
    r = run("fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5", "--report", "r.html")
    assert r.exit_code == 130, r.output
    assert "the results are saved in r.h5: `escfit report r.h5 --out r.html` writes it" in r.stderr
    assert sorted(p.name for p in work.iterdir()) == ["data.csv", "r.h5", "rig.toml"]
    monkeypatch.undo()
    again = run("report", work / "r.h5", "--out", work / "r.html")  # (undo left the folder too)
    assert again.exit_code == 0, again.output


def _signalling(fn, sig):
    def wrapped(*args, **kwargs):
        os.kill(os.getpid(), getattr(signal, sig))
        return fn(*args, **kwargs)

    return wrapped
