"""fit-many and its results folder: one batch at a time (an OS lock), refusal of another scene's
results, damaged checkpoints and results files, temporaries of a killed run, interruptions."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from escfit.analysis.recordings import read_unit_curve, write_unit_curve
from escfit.cli.main import cli
from escfit.core.errors import ResultsError
from escfit.results import load_fit
from escfit.study import fit_many, load_summary
from escfit.study.lock import LOCK_FILE, FolderBusy, folder_lock, lock_owner

from .conftest import DATASETS

FLEET = DATASETS / "fleet" / "angle"
SCENE = DATASETS / "fleet" / "scenes" / "angle.toml"
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Three units (u01, u02, u03) in one unit-curve file, one unit alone in a file, and a
    second scene: the first one's text with one more comment line (a different scene to fit-many)."""
    d = tmp_path_factory.mktemp("data")
    curve = read_unit_curve(FLEET / "recordings.csv")
    write_unit_curve(d / "three.csv", curve.select(np.flatnonzero(np.isin(curve.unit, ["u01", "u02", "u03"]))))
    one = curve.select(np.flatnonzero(curve.unit == "u04"))
    one.unit = np.full(one.swing.size, "", dtype=str)
    write_unit_curve(d / "u04.csv", one)
    (d / "other.toml").write_text(SCENE.read_text() + "\n# the same fit, another scene text\n")
    return d


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-c", "import sys; from escfit.cli.main import main; sys.argv[0] = 'escfit'; main()",
            "fit-many", *args]


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}


def _snapshot(folder: Path) -> dict[str, tuple[int, bytes]]:
    """Every file's time and bytes, but the lock's (whoever holds the lock rewrites it)."""
    return {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in sorted(folder.iterdir())
            if p.is_file() and p.name != LOCK_FILE}


def _scenes_of(folder: Path) -> set[str]:
    """The scene texts of the folder's results files."""
    out = set()
    for f in folder.glob("*.h5"):
        res = load_fit(f)
        out.add(res.attrs["scene"])
        res.tree.close()
    return out


# --- the lock -------------------------------------------------------------------------------------

_TRY_LOCK = ("import fcntl, os, sys\nfd = os.open(sys.argv[1], os.O_RDWR)\n"
             "try:\n    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)\nexcept BlockingIOError:\n    sys.exit(1)\n")


def _locked_elsewhere(folder: Path) -> bool:
    """Whether another process finds the folder's lock held."""
    return subprocess.run([sys.executable, "-c", _TRY_LOCK, str(folder / LOCK_FILE)]).returncode == 1


def test_lock_names_its_owner_and_is_reentrant_in_its_thread_only(tmp_path):
    with folder_lock(tmp_path) as path:
        assert path == tmp_path / LOCK_FILE and _locked_elsewhere(tmp_path)
        owner = lock_owner(tmp_path)
        assert owner["pid"] == os.getpid() and owner["host"] == socket.gethostname() and owner["started"]
        with folder_lock(tmp_path):  # fit_fleet holds it around fit_many
            pass
        assert _locked_elsewhere(tmp_path)  # still held after the inner block
        errors = []

        def other_thread():
            try:
                with folder_lock(tmp_path):
                    pass
            except FolderBusy as exc:
                errors.append(str(exc))

        t = threading.Thread(target=other_thread)
        t.start()
        t.join()
        assert len(errors) == 1 and f"(pid {os.getpid()} on {socket.gethostname()}, started" in errors[0]
        assert isinstance(FolderBusy("x"), ResultsError)
    assert not _locked_elsewhere(tmp_path)  # released; the file stays (removing it would race)
    with folder_lock(tmp_path):
        pass


def test_a_killed_holder_leaves_no_stale_lock(tmp_path):
    """kill -9 of the holder: the kernel drops the lock; the file still names the dead holder."""
    hold = ("import sys, time\nfrom escfit.study.lock import folder_lock\n"
            "with folder_lock(sys.argv[1]):\n    print('held', flush=True)\n    time.sleep(120)\n")
    p = subprocess.Popen([sys.executable, "-c", hold, str(tmp_path)], stdout=subprocess.PIPE, text=True, env=_env())
    try:
        assert p.stdout.readline().strip() == "held"
        with pytest.raises(FolderBusy, match=rf"another fit-many \(pid {p.pid} on "):
            with folder_lock(tmp_path):
                pass
    finally:
        p.kill()
        p.wait(timeout=60)
    assert lock_owner(tmp_path)["pid"] == p.pid
    with folder_lock(tmp_path):
        assert lock_owner(tmp_path)["pid"] == os.getpid()


def test_a_second_run_is_refused_while_the_folder_is_locked(data, tmp_path):
    """A fit-many process meets the lock this process holds: exit 2, one line naming the holder,
    nothing in the folder changed; once released, the same command skips the finished units."""
    out = tmp_path / "fits"
    first = fit_many(data / "three.csv", SCENE, out, workers=0, n_starts=2, units=["u01", "u02"])
    assert first.fitted == ["u01", "u02"]
    (out / "u02.h5").unlink()  # unfinished: the refused run must not fit it
    args = _cli(str(data / "three.csv"), "--scene", str(data / "other.toml"), "--out", str(out),
                "--workers", "0", "--n-starts", "2", "--quiet")
    with folder_lock(out):
        before, lock = _snapshot(out), (out / LOCK_FILE).read_bytes()
        r = subprocess.run(args, capture_output=True, text=True, env=_env(), timeout=300)
        assert _snapshot(out) == before and (out / LOCK_FILE).read_bytes() == lock
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    want = (rf"escfit: error: {re.escape(str(out))}: another fit-many \(pid {os.getpid()} on "
            rf"{re.escape(socket.gethostname())}, started \d{{4}}-\d\d-\d\dT[\d:]+\+00:00\) is writing here; "
            r"wait for it or choose another --out")
    assert len(lines) == 1 and re.fullmatch(want, lines[0]), r.stderr
    assert r.stdout == ""
    # the lock is free again: the batch's own command fits the rest and skips what is done
    r = CliRunner().invoke(cli, ["fit-many", str(data / "three.csv"), "--scene", str(SCENE), "--out", str(out),
                                 "--unit", "u01", "--unit", "u02", "--workers", "0", "--n-starts", "2", "--quiet"])
    assert r.exit_code == 0, r.output
    assert "1 fitted, 1 done before, 0 failed" in r.output


def test_two_batches_at_once_one_is_refused_and_the_folder_stays_consistent(data, tmp_path):
    """Two real processes, two scenes, one folder, started together: one batch runs, the other is
    refused (by the lock while the first runs, or by the scene check once it has finished); every
    results file and the summary carry the scene of the batch that ran."""
    out = tmp_path / "fits"
    out.mkdir()
    common = ["--workers", "0", "--n-starts", "2", "--quiet"]
    scenes = [SCENE, data / "other.toml"]
    procs = [subprocess.Popen(_cli(str(data / "three.csv"), "--scene", str(s), "--out", str(out), *common),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
             for s in scenes]
    results = [(p.wait(timeout=300), *p.communicate()) for p in procs]
    codes = sorted(r[0] for r in results)
    assert codes == [0, 2], results
    winner = next(i for i, r in enumerate(results) if r[0] == 0)
    refused = results[1 - winner][2]
    assert ("another fit-many (pid" in refused and "is writing here" in refused) or \
        "were fitted here with another scene or method" in refused, refused
    print(f"\nrefused by: {'the lock' if 'another fit-many' in refused else 'the scene check'}")
    text = scenes[winner].read_text()
    assert _scenes_of(out) == {text}
    s = load_summary(out)
    assert s.attrs["scene"] == text and list(s["status"].values) == ["ok", "ok", "ok"]
    assert not list(out.glob(".*.part"))
    assert not _locked_elsewhere(out)


# --- results of another scene or method -----------------------------------------------------------

def test_results_of_another_scene_are_refused_before_anything_is_written(data, tmp_path):
    out = tmp_path / "fits"
    fit_many(data / "three.csv", SCENE, out, workers=0, n_starts=2, units=["u01"])
    before = _snapshot(out)
    # the same unit, another scene or method: its results file says so
    with pytest.raises(ResultsError, match=r"\['u01'\] were fitted here with another scene or method"):
        fit_many(data / "three.csv", data / "other.toml", out, workers=0, n_starts=2, units=["u01"])
    with pytest.raises(ResultsError, match=r"\['u01'\] were fitted here with another scene or method"):
        fit_many(data / "three.csv", SCENE, out, workers=0, method="emcee", walkers=10, steps=20, units=["u01"])
    # other units, another scene: the folder's summary lists u01 as finished with the first one
    r = CliRunner().invoke(cli, ["fit-many", str(data / "u04.csv"), "--scene", str(data / "other.toml"),
                                 "--out", str(out), "--workers", "0", "--n-starts", "2", "--quiet"])
    assert r.exit_code == 2 and "['u01'] were fitted here with another scene or method" in r.output, r.output
    assert _snapshot(out) == before
    # the same scene may add units to the folder
    more = fit_many(data / "u04.csv", SCENE, out, workers=0, n_starts=2)
    assert more.fitted == ["u04"] and _scenes_of(out) == {SCENE.read_text()}


# --- damaged checkpoints and results files --------------------------------------------------------

def test_a_damaged_checkpoint_restarts_its_unit_and_says_so(data, tmp_path):
    out = tmp_path / "fits"
    out.mkdir()
    (out / "u04.h5.emcee").write_bytes(os.urandom(4096))
    lines: list[str] = []
    res = fit_many(data / "u04.csv", SCENE, out, workers=0, method="emcee", walkers=10, steps=20, progress=lines.append)
    assert res.fitted == ["u04"] and not res.failed
    note = next(line for line in lines if "checkpoint" in line)
    assert note.startswith("u04: checkpoint u04.h5.emcee not resumable (") and note.endswith("started afresh"), lines
    assert not (out / "u04.h5.emcee").exists()
    s = load_summary(out)
    assert str(s["status"].sel(unit="u04").values) == "ok"
    assert any("started afresh" in w for w in json.loads(str(s["warnings"].sel(unit="u04").values)))
    fit = load_fit(out / "u04.h5")
    assert fit.attrs["method"] == "emcee" and not fit.attrs["resumed"]
    fit.tree.close()


def test_a_truncated_results_file_is_refitted(data, tmp_path):
    out = tmp_path / "fits"
    fit_many(data / "three.csv", SCENE, out, workers=0, n_starts=2, units=["u01", "u02"])
    whole = (out / "u02.h5").read_bytes()
    (out / "u02.h5").write_bytes(whole[: len(whole) // 2])  # an HDF5 signature, then nothing
    again = fit_many(data / "three.csv", SCENE, out, workers=0, n_starts=2, units=["u01", "u02"])
    assert again.skipped == ["u01"] and again.fitted == ["u02"]
    load_fit(out / "u02.h5").tree.close()


def test_results_and_summary_carry_checksums(data, tmp_path):
    import h5py

    fit_many(data / "three.csv", SCENE, tmp_path, workers=0, n_starts=2, units=["u01"])
    for name, var in (("u01.h5", "least_squares/value"), ("summary.nc", "estimate")):
        with h5py.File(tmp_path / name, "r") as f:
            assert f[var].fletcher32, name


# --- temporaries of a killed run ------------------------------------------------------------------

def test_temporaries_a_killed_run_left_are_removed_and_only_those(data, tmp_path):
    out = tmp_path / "fits"
    out.mkdir()
    owned = [".summary.nc.k3j_x9a1.part", ".u01.h5.0ylwciyd.part", ".u01.h5.emcee.ab12cd34.part"]
    foreign = [".notes.txt.0ylwciyd.part", ".u01.h5.part", "u01.h5.0ylwciyd.part", ".u09.h5.0ylwciyd.part"]
    for name in owned + foreign:
        (out / name).write_bytes(b"half a file")
    lines: list[str] = []
    res = fit_many(data / "three.csv", SCENE, out, workers=0, n_starts=2, units=["u01"], progress=lines.append)
    assert res.fitted == ["u01"]
    assert sorted(p.name for p in out.iterdir() if p.name.endswith(".part")) == sorted(foreign)
    assert any(line.startswith("removed 3 temporary file(s)") for line in lines), lines


# --- interruptions --------------------------------------------------------------------------------

def test_an_interrupt_keeps_finished_units_and_releases_the_lock(data, tmp_path):
    out = tmp_path / "fits"

    def interrupt_after_first_unit(line: str) -> None:
        if "fitted in" in line:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        fit_many(data / "three.csv", SCENE, out, workers=0, n_starts=2, progress=interrupt_after_first_unit)
    assert sorted(p.name for p in out.glob("*.h5")) == ["u01.h5"] and not (out / "summary.nc").exists()
    assert not list(out.glob(".*.part")) and not _locked_elsewhere(out)
    rest = fit_many(data / "three.csv", SCENE, out, workers=0, n_starts=2)
    assert rest.skipped == ["u01"] and rest.fitted == ["u02", "u03"]


def test_sigterm_stops_the_batch_like_ctrl_c(data, tmp_path):
    """A real SIGTERM during the second (emcee) unit: exit 130 with the way on, the finished unit
    kept, no temporaries, the lock released."""
    out = tmp_path / "fits"
    args = _cli(str(data / "three.csv"), "--scene", str(SCENE), "--out", str(out), "--method", "emcee",
                "--walkers", "10", "--steps", "400", "--workers", "0", "--quiet")
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    deadline = time.monotonic() + 240
    while not (out / "u01.h5").exists() and p.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(0.5)  # into the second unit's sampling
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert "interrupted; the units fitted so far are saved in" in err
    assert (out / "u01.h5").exists() and not (out / "u03.h5").exists()
    assert not list(out.glob(".*.part")) and not _locked_elsewhere(out)
    load_fit(out / "u01.h5").tree.close()


def test_a_hangup_after_the_last_unit_still_writes_the_summary(data, tmp_path, monkeypatch):
    """SIGHUP (a closed terminal) while the summary is made: the summary is finished first, then
    the batch ends as interrupted (exit 130), nothing left to rerun."""
    import importlib

    from click.testing import CliRunner

    from escfit.cli.main import cli

    batch = importlib.import_module("escfit.study.batch")
    real = batch.summarize

    def hangup(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGHUP)
        return real(*args, **kwargs)

    monkeypatch.setattr(batch, "summarize", hangup)
    out = tmp_path / "fits"
    r = CliRunner().invoke(cli, ["fit-many", str(data / "u04.csv"), "--scene", str(SCENE), "--out", str(out),
                                 "--workers", "0", "--n-starts", "2", "--quiet"])
    assert r.exit_code == 130, r.output
    assert (out / "summary.nc").exists() and (out / "u04.h5").exists()
    assert not list(out.glob(".*.part")) and not _locked_elsewhere(out)
