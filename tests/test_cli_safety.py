"""The command line never destroys its inputs and refuses bad outputs and options before any work.

Every refusal exits with status 2 and one line on stderr naming the file, key or value, and
leaves the folder exactly as it was: no new file, no changed byte.
"""

from __future__ import annotations

import errno
import os
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.cli.main import cli

from .conftest import DATASETS

RIG_DATA = DATASETS / "friction" / "monday1965_session_1095_steel.csv"
RIG_SCENE = DATASETS / "friction" / "monday1965_rig.toml"
SIM_SCENE = DATASETS / "scenes" / "horology_rk4_case.toml"
UNIT_SCENE = DATASETS / "monday1965" / "synthetic" / "unit3_load330.66g.toml"


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def listing(folder: Path) -> dict[str, bytes | None]:
    """Every entry under ``folder`` (hidden ones too) with the bytes of its files."""
    return {str(p.relative_to(folder)): (None if p.is_dir() or not p.exists() else p.read_bytes())
            for p in sorted(folder.rglob("*"))}


def assert_refused(folder: Path, args, *fragments) -> str:
    """Run ``escfit ARGS``: exit 2, one stderr line holding every fragment, ``folder`` unchanged."""
    before = listing(folder)
    r = run(*args)
    assert r.exit_code == 2, (r.exit_code, r.output, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    assert listing(folder) == before, "a refused command changed the folder"
    return lines[0]


@pytest.fixture
def work(tmp_path, monkeypatch):
    """A folder holding a rig recording, its scene, a simulation scene and a fit recipe."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(RIG_DATA, tmp_path / "data.csv")
    shutil.copy(RIG_SCENE, tmp_path / "rig.toml")
    shutil.copy(SIM_SCENE, tmp_path / "sim.toml")
    shutil.copy(UNIT_SCENE, tmp_path / "unit.toml")
    (tmp_path / "recipe.toml").write_text('data = "data.csv"\nscene = "rig.toml"\n')
    return tmp_path


@pytest.fixture(scope="module")
def saved_fit(tmp_path_factory) -> Path:
    """A least-squares fit of the rig recording, saved once for the report and summary cases."""
    out = tmp_path_factory.mktemp("saved") / "fit.h5"
    r = run("fit", RIG_DATA, "--scene", RIG_SCENE, "--out", out)
    assert r.exit_code == 0, r.output
    return out


# --- 1. an output is never an input, nor another output, --force or not -----------------------

@pytest.mark.parametrize("args, fragments", [
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "data.csv", "--force"], ["--out is the data file"]),
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "./data.csv", "--force"], ["--out is the data file"]),
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "rig.toml", "--force"], ["--out is the scene file"]),
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5", "--report", "r.h5", "--force"],
     ["r.h5: --report is the --out file"]),
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5", "--report", "data.csv", "--force"],
     ["--report is the data file"]),
    (["simulate", "sim.toml", "--out", "sim.toml", "--force"], ["--out is the scene file"]),
    (["simulate", "unit.toml", "--recorder", "unit-curve", "--out", "unit.toml", "--force"],
     ["--out is the scene file"]),
])
def test_an_output_naming_an_input_is_refused(work, args, fragments):
    assert_refused(work, args, *fragments)


def test_a_checkpoint_naming_the_data_is_refused(work):
    shutil.copy(work / "data.csv", work / "x.emcee")  # the sampler's <out>.emcee would replace the data
    assert_refused(work, ["fit", "x.emcee", "--scene", "rig.toml", "--method", "emcee", "--out", "x", "--force"],
                   "x.emcee: the checkpoint (--out + .emcee) is the data file")


def test_symlinks_and_hard_links_to_an_input_are_refused(work):
    (work / "link.csv").symlink_to(work / "data.csv")
    os.link(work / "rig.toml", work / "hard.toml")
    assert_refused(work, ["fit", "data.csv", "--scene", "rig.toml", "--out", "link.csv", "--force"],
                   "link.csv: --out is the data file")
    assert_refused(work, ["fit", "data.csv", "--scene", "rig.toml", "--out", "hard.toml", "--force"],
                   "hard.toml: --out is the scene file")
    assert_refused(work, ["simulate", "sim.toml", "--out", work / "sub" / ".." / "sim.toml", "--force"],
                   "--out is the scene file")


@pytest.mark.parametrize("line, fragment", [
    ('out = "data.csv"', "--out is the data file"),
    ('out = "rig.toml"', "--out is the scene file"),
    ('out = "recipe.toml"', "--out is the recipe file"),
    ('report = "rig.toml"', "--report is the scene file"),
    ('out = "r.h5"\nreport = "r.h5"', "--report is the --out file"),
])
def test_a_recipe_naming_its_own_inputs_as_outputs_is_refused(work, line, fragment):
    (work / "recipe.toml").write_text((work / "recipe.toml").read_text() + line + "\n")
    assert_refused(work, ["fit", "recipe.toml", "--force"], fragment)


def test_a_report_replacing_its_results_file_is_refused(saved_fit):
    folder = saved_fit.parent
    assert_refused(folder, ["report", saved_fit, "--out", saved_fit, "--force"],
                   f"{saved_fit}: --out is the results file")
    assert_refused(folder, ["report", saved_fit, "--out", folder / "." / "fit.h5", "--force", "--format", "md"],
                   "--out is the results file")


def test_make_report_refuses_its_results_file_in_python(saved_fit):
    from escfit.core.errors import ResultsError
    from escfit.report import make_report

    before = saved_fit.read_bytes()
    with pytest.raises(ResultsError, match="the report is the results file"):
        make_report(saved_fit, saved_fit, force=True)
    assert saved_fit.read_bytes() == before


def test_make_report_refuses_a_folder_as_its_file(saved_fit, tmp_path):
    from escfit.core.errors import ResultsError
    from escfit.report import make_report

    with pytest.raises(ResultsError, match="the report is a folder; give a file name"):
        make_report(saved_fit, tmp_path, force=True)
    assert list(tmp_path.iterdir()) == []


def test_fit_refuses_its_data_as_output_in_python(work):
    from escfit import fit
    from escfit.core.errors import ResultsError

    before = listing(work)
    with pytest.raises(ResultsError, match="out is the data file"):
        fit(work / "rig.toml", work / "data.csv", out=work / "data.csv", force=True)
    assert listing(work) == before


# --- 2. output folders and options are checked before any work ---------------------------------

@pytest.mark.parametrize("args, fragments", [
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "no/such/r.h5"],
     ["no/such/r.h5: the folder of --out does not exist (no/such)"]),
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "data.csv/r.h5"],
     ["data.csv/r.h5: the folder of --out is not a folder (data.csv is a file)"]),
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5", "--report", "no/r.html"],
     ["no/r.html: the folder of --report does not exist"]),
    (["fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5", "--report", "rig.toml/r.html"],
     ["the folder of --report is not a folder"]),
    (["fit", "recipe.toml"], ["the folder of --report does not exist"]),  # the recipe's report
    (["simulate", "sim.toml", "--out", "no/x.nc"], ["no/x.nc: the folder of --out does not exist"]),
    (["simulate", "unit.toml", "--recorder", "pulses", "--out", "no/x.csv"], ["the folder of --out does not exist"]),
])
def test_an_output_folder_that_cannot_take_the_file_is_refused_up_front(work, args, fragments):
    (work / "recipe.toml").write_text((work / "recipe.toml").read_text() + 'report = "gone/r.html"\n')
    assert_refused(work, args, *fragments)


def test_a_report_into_a_missing_folder_is_refused(saved_fit):
    assert_refused(saved_fit.parent, ["report", saved_fit, "--out", saved_fit.parent / "no" / "r.html"],
                   "the folder of --out does not exist")


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes to read-only folders")
def test_a_read_only_output_folder_is_refused_up_front(work):
    ro = work / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert_refused(work, ["fit", "data.csv", "--scene", "rig.toml", "--out", ro / "r.h5"],
                       "the folder of --out is not writable")
        assert_refused(work, ["fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5", "--report", ro / "r.html"],
                       "the folder of --report is not writable")
    finally:
        ro.chmod(0o755)


def test_an_unwritable_output_folder_is_refused_whoever_runs(work, monkeypatch):
    """As above for any user (root may write to read-only folders): the folder's access is asked once."""
    import escfit.core.atomic as atomic

    monkeypatch.setattr(atomic.os, "access", lambda path, mode: Path(path).name != "ro")
    (work / "ro").mkdir()
    assert_refused(work, ["fit", "data.csv", "--scene", "rig.toml", "--out", "ro/r.h5"],
                   "ro/r.h5: the folder of --out is not writable (ro)")
    assert_refused(work, ["simulate", "sim.toml", "--out", "ro/x.nc"], "the folder of --out is not writable")


# --- 3. seeds ----------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", ["-1", str(2**40), "4294967296", "x"])
@pytest.mark.parametrize("command", ["fit", "simulate"])
def test_a_seed_outside_numpys_range_exits_2(work, command, seed):
    args = (["fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5"] if command == "fit"
            else ["simulate", "unit.toml", "--recorder", "pulses", "--out", "p.csv"])
    assert_refused(work, [*args, "--seed", seed], "--seed", seed)


def test_the_largest_seed_is_taken(work):
    r = run("simulate", "unit.toml", "--recorder", "unit-curve", "--out", "p.csv", "--seed", 2**32 - 1)
    assert r.exit_code == 0, r.output
    assert f"seed {2**32 - 1}" in r.output and (work / "p.csv").exists()


def test_fit_refuses_a_bad_seed_in_python_before_any_work(work):
    from escfit import fit
    from escfit.core.errors import FitError

    before = listing(work)
    for seed in (-1, 2**40, 1.5, True):
        with pytest.raises(FitError, match="seed must be a whole number"):
            fit(work / "rig.toml", work / "data.csv", method="emcee", out=work / "r.h5", seed=seed)
    assert listing(work) == before


# --- 4. recipe values of the wrong kind --------------------------------------------------------

@pytest.mark.parametrize("key, value", [
    ("data", "5"), ("scene", "true"), ("method", "3"), ("method", '"bayes"'), ("walkers", '"many"'),
    ("walkers", "1"), ("title", "7"), ("report", "[]"), ("out", "{}"), ("out", '""'), ("seed", "-1"),
    ("seed", str(2**40)), ("seed", '"4"'), ("seed", "2.0"), ("burn", "-3"), ("moves", '"walk"'),
    ("notch_deg", '"6"'), ("notch_deg", "-6"), ("unit", "true"), ("solver", "4"), ("format", "[1]"),
    ("material", "3"),
])
def test_a_recipe_value_of_the_wrong_kind_names_file_and_key(work, key, value):
    lines = {"data": '"data.csv"', "scene": '"rig.toml"', key: value}
    recipe = work / "recipe.toml"
    recipe.write_text("".join(f"{k} = {v}\n" for k, v in lines.items()))
    line = assert_refused(work, ["fit", "recipe.toml"], f"recipe.toml (recipe).{key}: {key} must be")
    assert line.endswith(f"got {tomllib.loads(f'v = {value}')['v']!r}")


# --- 5. checkpoints: refused runs leave none; a damaged one is refused naming --force -----------

def test_a_run_refused_before_sampling_leaves_no_checkpoint(work):
    # too few walkers for the rig's five parameters: refused after least squares, before sampling
    assert_refused(work, ["fit", "data.csv", "--scene", "rig.toml", "--method", "emcee", "--walkers", "8",
                          "--steps", "20", "--out", "r.h5"], "emcee needs at least 10 walkers")


def test_a_posterior_that_is_minus_infinity_everywhere_leaves_no_checkpoint(work, monkeypatch):
    """The sampler saves its first checkpoint after its first steps: refused priors write none."""
    from escfit.friction.problem import RigProblem
    from escfit.inference import mcmc

    saves = []
    monkeypatch.setattr(mcmc, "save_checkpoint", lambda *a, **k: saves.append(a))
    monkeypatch.setattr(RigProblem, "log_prob", lambda self, vec: -np.inf)
    assert_refused(work, ["fit", "data.csv", "--scene", "rig.toml", "--method", "emcee", "--walkers", "10",
                          "--steps", "20", "--out", "r.h5"], "could not place the walkers")
    assert saves == []


def test_a_damaged_checkpoint_is_refused_naming_force_before_any_work(work):
    (work / "r.h5.emcee").write_bytes(b"\x00garbage, not HDF5\xff" * 50)
    args = ["fit", "data.csv", "--scene", "rig.toml", "--method", "emcee", "--walkers", "10", "--steps", "20",
            "--out", "r.h5"]
    assert_refused(work, [*args, "--resume"], "r.h5.emcee: cannot resume from this checkpoint", "--force")
    (work / "r.h5.emcee").write_text("")
    assert_refused(work, [*args, "--resume"], "cannot resume", "--force")
    (work / "r.h5.emcee").unlink()
    assert_refused(work, [*args, "--resume"], "r.h5.emcee: nothing to resume")


def test_a_foreign_hdf5_file_as_checkpoint_is_refused(work):
    assert run("simulate", "sim.toml", "--swings", "2", "--out", "r.h5.emcee").exit_code == 0
    assert_refused(work, ["fit", "data.csv", "--scene", "rig.toml", "--method", "emcee", "--walkers", "10",
                          "--steps", "20", "--out", "r.h5", "--resume"], "not an escfit sampler checkpoint",
                   "--force")


# --- 6. a full disk while writing a simulation ------------------------------------------------

def test_simulate_out_on_a_full_disk_exits_2_and_leaves_nothing(work, monkeypatch):
    import escfit.core.h5write as h5write

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(h5write.os, "fsync", full)
    assert_refused(work, ["simulate", "sim.toml", "--swings", "3", "--out", "run.nc"], "run.nc:", "disk is full")


def test_simulate_out_is_written_with_checksums(work):
    import h5py

    r = run("simulate", "sim.toml", "--swings", "3", "--out", "run.nc")
    assert r.exit_code == 0, r.output
    with h5py.File(work / "run.nc", "r") as f:
        assert f["amplitude"].fletcher32
    assert sorted(p.name for p in work.iterdir()) == ["data.csv", "recipe.toml", "rig.toml", "run.nc", "sim.toml",
                                                      "unit.toml"]


# --- 7. summary of damaged or foreign files ---------------------------------------------------

@pytest.mark.parametrize("content", [b"", b"\x89HDF\r\n\x1a\n" + b"\x00" * 100, b"not a results file\n", "sim"])
def test_summary_of_a_damaged_or_foreign_file_exits_2(work, content):
    path = work / "odd.h5"
    if content == "sim":
        assert run("simulate", "sim.toml", "--swings", "2", "--out", path).exit_code == 0
    else:
        path.write_bytes(content)
    for extra in ([], ["--json"], ["--csv"]):
        assert_refused(work, ["summary", path, *extra], "odd.h5")


def test_summary_of_a_folder_that_is_no_fleet_exits_2(work):
    (work / "odd.h5").mkdir()
    assert_refused(work, ["summary", "odd.h5"], "odd.h5")


def test_summary_of_a_truncated_fit_exits_2(saved_fit, tmp_path):
    cut = tmp_path / "cut.h5"
    cut.write_bytes(saved_fit.read_bytes()[: saved_fit.stat().st_size // 2])
    assert_refused(tmp_path, ["summary", cut], "cut.h5")
