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


def tamper(path, **changes):
    """Rewrite datasets through h5py (valid checksums): ``name=fn(old values)``."""
    with h5py.File(path, "r+") as f:
        for name, fn in changes.items():
            data = fn(f[name][()])
            del f[name]
            f.create_dataset(name, data=data, fletcher32=True)


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
