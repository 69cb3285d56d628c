"""Records with one real-world artefact each, through ``escfit init --pendulum`` and ``escfit fit``.

Each class of :mod:`tests.artefacts.make` is a pendulum's free decay with known truth (omega0, C,
R, the free window, the verdict a careful analysis should reach) and one artefact a real record
has: a hand at the start, a hold, a push, a faulty clock, another channel, another quantity.  The
test runs what a new user runs and asserts that the outcome is one the truth accepts (a fit with
omega0 within 0.5 %, C and R within the larger of 3 standard errors and 15 %, on the true free
window; or a refusal naming the reason) -- see tests/artefacts/score.py for the tolerances and
benchmarks/artefact_suite.py for the same classes over more seeds and full-length records.

The classes the analysis gets wrong today are strict expected failures naming what happens, so
each one flips loudly when it is fixed.
"""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from escfit.cli.main import cli

from .artefacts import CLASSES, make
from .artefacts.score import ACCEPTS, classify, estimates_right, read_result

pytestmark = pytest.mark.slow  # some 20 fits of init + fit: run in CI's slow step (.ci/run)

SEED = 3  # a 1.17 s period sampled at 28 Hz: about 650 rows in 20 periods, a short fit
PERIODS = 20

# what today's analysis does with the classes it gets wrong (the lead removes a mark when its fix lands)
FAILS_TODAY: dict[str, str] = {
}
SLOW = {"long_jitter"}


def run(name: str, tmp_path, monkeypatch):
    art = make(name, SEED, periods=None if name in SLOW else PERIODS)
    monkeypatch.chdir(tmp_path)
    data = tmp_path / f"{name}.csv"
    data.write_text(art.csv)
    runner = CliRunner()
    r = runner.invoke(cli, ["init", data.name, "--pendulum"])
    result = None
    if r.exit_code == 0:
        r = runner.invoke(cli, ["fit", data.name, "--scene", f"{name}.toml", "--out", "r.h5"])
        if r.exit_code == 0:
            result = read_result(tmp_path / "r.h5")
    return art, r, result


def _params():
    for name in CLASSES:
        marks = []
        if name in FAILS_TODAY:
            marks.append(pytest.mark.xfail(reason=FAILS_TODAY[name], strict=True))
        if name in SLOW:
            marks.append(pytest.mark.slow)
        yield pytest.param(name, marks=marks, id=name)


@pytest.mark.parametrize("name", list(_params()))
def test_artefact_verdict_and_window(name, tmp_path, monkeypatch):
    art, r, result = run(name, tmp_path, monkeypatch)
    truth = art.truth
    outcome = classify(truth, r.exit_code, r.output, result)
    detail = r.output[-600:] if result is None else (
        f"errors {estimates_right(truth, result)[1]}, fitted from {result['ref']} [{result['t_first']:.2f}, "
        f"{result['t_last']:.2f}] s, true window {truth.all_windows()}, notes {result['notes'][:3]}")
    assert ACCEPTS.get(outcome) in truth.accept, f"{name}: {outcome}, expected {truth.accept}: {detail}"
