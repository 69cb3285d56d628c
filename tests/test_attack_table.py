"""An attack on the command line: one row per class of bad input, each refused the same way.

Every row builds its hostile input in a fresh folder and runs one ``escfit`` command; the
command must exit with status 2, print exactly one line on stderr naming the file, key or
option and the value, write nothing and change nothing (every file's bytes, links, FIFOs and
device nodes are compared before and after).  The classes are those a user's real files and
fingers produce (spreadsheet exports, other encodings and line ends, the wrong file, special
files), scene values no balance can have, options no run can use, and outputs that are not
results files.  docs/reliability.md lists them with the defects they found.
"""

from __future__ import annotations

import gzip
import os
import shutil
import socket
import stat

import pytest

from .attack_files import HOSTILE_FILES
from .conftest import DATASETS
from .test_cli_safety import run
from .test_fuzz_inputs import memory_ceiling

RIG = DATASETS / "friction" / "monday1965_session_1095_steel.csv"
RIG_SCENE = DATASETS / "friction" / "monday1965_rig.toml"
SIM = DATASETS / "scenes" / "horology_rk4_case.toml"
UNIT_SCENE = DATASETS / "monday1965" / "synthetic" / "unit3_load330.66g.toml"
TS_SCENE = DATASETS / "recordings" / "timeseries_scene.toml"
TS = DATASETS / "recordings" / "monday_timeseries.csv"
FIT = ["fit", "data.csv", "--scene", "rig.toml", "--out", "r.h5"]


def snapshot(folder) -> dict:
    """Every entry (hidden ones too), not following links: bytes of files, targets of links, kinds."""
    out = {}
    for p in sorted(folder.rglob("*")):
        mode = os.lstat(p).st_mode
        key = str(p.relative_to(folder))
        if stat.S_ISLNK(mode):
            out[key] = ("link", os.readlink(p))
        elif stat.S_ISREG(mode):
            out[key] = ("file", p.read_bytes())
        else:
            out[key] = ("other", stat.S_IFMT(mode))
    return out


def rig_text() -> str:
    return RIG.read_text()


def rig_rows(fn) -> str:
    """The rig readings with ``fn`` applied to each data row's cells."""
    lines = rig_text().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("load_g"))
    return "\n".join(lines[:head + 1] + [fn(line.split(",")) for line in lines[head + 1:]]) + "\n"


def scene_with(old: str, new: str):
    def setup(w):
        (w / "rig.toml").write_text((w / "rig.toml").read_text().replace(old, new, 1))
    return setup


def data(text: str | bytes):
    def setup(w):
        target = w / "data.csv"
        target.write_bytes(text if isinstance(text, bytes) else text.encode())
    return setup


def special(name: str, kind: str):
    def setup(w):
        p = w / name
        if kind == "fifo":
            os.mkfifo(p)
        elif kind == "socket":
            s = socket.socket(socket.AF_UNIX)
            s.bind(str(p))
            s.close()
        elif kind == "dangling":
            p.symlink_to(w / "nowhere")
        elif kind == "zero":
            p.symlink_to("/dev/zero")
        elif kind == "device":  # a node like /dev/null, made in the test folder
            os.mknod(p, stat.S_IFCHR | 0o666, os.makedev(1, 3))
        elif kind == "folder":
            p.mkdir()
        elif kind == "link-to-file":
            (w / "target.h5").write_bytes(b"an earlier result")
            p.symlink_to(w / "target.h5")
    return setup


def hdf5_data(w):
    import h5py

    (w / "data.csv").unlink()
    with h5py.File(w / "data.csv", "w") as f:
        f["chain"] = [[1.0, 2.0]]


def angles_only(w):
    """The shipped sampled decay without its time column (for --sample-rate)."""
    rows = [line.split(",")[1] for line in TS.read_text().splitlines()[1:] if line[:1].isdigit()]
    (w / "ts.csv").write_text("theta_deg\n" + "\n".join(rows) + "\n")


def both(*setups):
    def setup(w):
        for s in setups:
            s(w)
    return setup


def recipe(text: str):
    def setup(w):
        (w / "recipe.toml").write_text(text)
    return setup


LONG = "r" * 250
DEEP = 'model = "friction_rig"\nx = ' + "[" * 3000 + "]" * 3000 + "\n"

# (class, setup of the folder, command, fragments of the one stderr line)
ATTACKS = [
    # -- real-world file shapes given as data ---------------------------------------------------
    ("excel-quoted-thousands", data(rig_rows(lambda c: ",".join(f'"{x}"' for x in c)).replace(
        '"1.2000"', '"1,200.0"')), FIT, ["data.csv"]),
    ("semicolon-decimal-comma-units-row", data(rig_text().split("load_g")[0] + "load_g;dw_g;speed_ft_s;material\n"
                                              "g;g;ft/s;\n1,2000;0,0723;3;steel\n1,7000;0,0800;5;steel\n"),
     FIT, ["data.csv"]),
    ("time-of-day-column", data("time,theta_deg\n12:00:00.000,10\n12:00:00.010,9\n12:00:00.020,8\n"),
     ["fit", "data.csv", "--scene", "ts.toml", "--out", "r.h5"], ["data.csv"]),
    ("cr-cr-lf-line-ends-with-a-bad-row", data(rig_text().replace("\n", "\r\r\n").replace("0.0723", "x.0723")),
     FIT, ["data.csv", "x.0723"]),
    ("utf16-file", data(rig_text().encode("utf-16")), FIT, ["data.csv"]),
    ("nul-bytes", data(rig_text().replace("0.0723", "0.07\x0023").encode()), FIT, ["data.csv"]),
    ("gzip-named-csv", data(gzip.compress(rig_text().encode())), FIT, ["data.csv"]),
    ("hdf5-file-as-data", hdf5_data, FIT, ["data.csv"]),
    ("empty-file", data(""), FIT, ["data.csv"]),
    ("header-only", data("load_g,dw_g,speed_ft_s,material\n"), FIT, ["data.csv"]),
    ("folder-as-data", both(lambda w: (w / "data.csv").unlink(), special("data.csv", "folder")), FIT,
     ["data.csv", "directory"]),
    ("fifo-as-data", both(lambda w: (w / "data.csv").unlink(), special("data.csv", "fifo")), FIT,
     ["data.csv: is a FIFO"]),
    ("dev-zero-link-as-data", both(lambda w: (w / "data.csv").unlink(), special("data.csv", "zero")), FIT,
     ["data.csv: is a character device"]),
    ("socket-as-data", both(lambda w: (w / "data.csv").unlink(), special("data.csv", "socket")), FIT,
     ["data.csv: is a socket"]),
    ("dangling-link-as-data", both(lambda w: (w / "data.csv").unlink(), special("data.csv", "dangling")), FIT,
     ["data.csv: data file not found"]),
    # -- scene attacks ----------------------------------------------------------------------------
    ("duplicate-key", scene_with("[friction]\n", "[friction]\nload_ref = \"2 gf\"\n"), FIT, ["rig.toml"]),
    ("wrong-case-key", scene_with("mu = {", "Mu = {"), FIT, ["rig.toml", "Mu"]),
    ("min-above-max", scene_with("min = 0.0, max = 1.0", "min = 1.0, max = 0.0"), FIT, ["rig.toml", "above max"]),
    ("prior-outside-bounds", scene_with("max = 1.0 }", 'max = 1.0, prior = "normal(50, 1)" }'), FIT,
     ["rig.toml", "friction.mu"]),
    ("nan-string-value", scene_with("value = 0.12", 'value = "nan"'), FIT, ["rig.toml", "nan"]),
    ("inf-string-bound", scene_with("max = 1.0", 'max = "inf"'), FIT, ["rig.toml", "inf"]),
    ("max-1e308", scene_with("max = 1.0", "max = 1e308"), FIT, ["rig.toml [friction.mu].max", "1e+308"]),
    ("prior-sd-1e-300", scene_with("max = 1.0 }", 'max = 1.0, prior = "normal(0.05, 1e-300)" }'), FIT,
     ["rig.toml [friction.mu].prior", "1e-300"]),
    ("negative-inertia", lambda w: (w / "unit.toml").write_text((w / "unit.toml").read_text().replace(
        "[oscillator]\n", '[oscillator]\ninertia = "-1 g*cm^2"\n', 1)), ["simulate", "unit.toml"], ["unit.toml"]),
    ("hairspring-of-a-million-pieces", lambda w: (w / "unit.toml").write_text(
        'model = "balance"\n[oscillator]\ntheta0 = 1.0\n[effects.hairspring]\nangles = ['
        + ", ".join(f"{k * 1e-6:.6f}" for k in range(1, 1_000_000)) + "]\nomega0 = [" + ", ".join(["15.0"] * 1_000_000)
        + "]\n"), ["simulate", "unit.toml"], ["unit.toml", "MB"]),
    ("nested-3000-deep", lambda w: (w / "rig.toml").write_text(DEEP), FIT, ["rig.toml", "nested"]),
    ("recipe-naming-itself-as-data", recipe('data = "recipe.toml"\nscene = "rig.toml"\nout = "r.h5"\n'),
     ["fit", "recipe.toml"], ["recipe.toml"]),
    ("recipe-naming-itself-as-scene", recipe('data = "data.csv"\nscene = "recipe.toml"\nout = "r.h5"\n'),
     ["fit", "recipe.toml"], ["recipe.toml"]),
    ("fifo-as-scene", special("fifo.toml", "fifo"), ["simulate", "fifo.toml"], ["fifo.toml: is a FIFO"]),
    ("fifo-as-recipe", special("fifo.toml", "fifo"), ["fit", "fifo.toml"], ["fifo.toml: is a FIFO"]),
    # -- options no run can use ------------------------------------------------------------------
    ("checkpoint-every-nan", None, [*FIT, "--method", "emcee", "--checkpoint-every", "nan"], ["--checkpoint-every",
                                                                                            "'nan'"]),
    ("checkpoint-every-inf", None, [*FIT, "--method", "emcee", "--checkpoint-every", "inf"], ["--checkpoint-every"]),
    ("simulate-noise-nan", None, ["simulate", "unit.toml", "--recorder", "unit-curve", "--out", "u.csv", "--noise",
                                  "nan"], ["--noise", "'nan'"]),
    ("simulate-noise-inf", None, ["simulate", "unit.toml", "--recorder", "unit-curve", "--out", "u.csv", "--noise",
                                  "inf"], ["--noise"]),
    ("notch-deg-1e-300", None, ["fit", "u.csv", "--scene", "unit.toml", "--notch-deg", "1e-300"],
     ["--notch-deg", "1e-300"]),
    ("notch-deg-nan", None, ["simulate", "unit.toml", "--recorder", "unit-curve", "--out", "u.csv", "--notch-deg",
                             "nan"], ["--notch-deg"]),
    ("rk4-step-nan", None, ["simulate", "sim.toml", "--solver", "rk4", "--h", "nan"], ["--h"]),
    ("scale-inf", None, [*FIT, "--scale", "inf"], ["--scale"]),
    ("counts-per-turn-zero", None, [*FIT, "--counts-per-turn", "0"], ["--counts-per-turn"]),
    ("charts-ratio-nan", None, ["charts", "--out", "c", "--c-over-omega0", "nan"], ["--c-over-omega0"]),
    ("walkers-1", None, [*FIT, "--method", "emcee", "--walkers", "1"], ["--walkers"]),
    ("walkers-1e8", None, [*FIT, "--method", "emcee", "--walkers", "100000000"], ["--walkers", "100000000"]),
    ("walkers-memory", None, [*FIT, "--method", "emcee", "--walkers", "100000", "--steps", "9000000"],
     ["GB"]),
    ("steps-0", None, [*FIT, "--method", "emcee", "--steps", "0"], ["--steps", "'0'"]),
    ("steps-1e12", None, [*FIT, "--method", "emcee", "--steps", "1000000000000"], ["--steps"]),
    ("max-steps-1e9", None, [*FIT, "--method", "emcee", "--max-steps", "1000000000"], ["--max-steps"]),
    ("resume-with-least-squares", None, [*FIT, "--resume"], ["--resume continues an interrupted emcee run"]),
    ("sample-rate-1e308-hz", angles_only,
     ["fit", "ts.csv", "--scene", "ts.toml", "--format", "raw", "--sample-rate", "1e308 Hz", "--angle-unit", "deg",
      "--out", "r.h5"], ["ts.csv"]),
    # -- outputs that are not results files --------------------------------------------------------
    ("out-trailing-slash", None, ["simulate", "sim.toml", "--out", "res/"], ["res/", "names a folder"]),
    ("out-is-a-folder", special("res", "folder"), ["simulate", "sim.toml", "--out", "res", "--force"], ["res"]),
    ("out-fifo-force", special("o.nc", "fifo"), ["simulate", "sim.toml", "--out", "o.nc", "--force"],
     ["o.nc: is a FIFO"]),
    ("out-device-force", special("null", "device"), ["simulate", "sim.toml", "--out", "null", "--force"],
     ["null: is a character device"]),
    ("out-socket-force", special("o.nc", "socket"), ["simulate", "sim.toml", "--out", "o.nc", "--force"],
     ["o.nc: is a socket"]),
    ("out-dangling-link", special("o.nc", "dangling"), ["simulate", "sim.toml", "--out", "o.nc"],
     ["o.nc: is a symbolic link"]),
    ("out-link-to-file-force", special("o.nc", "link-to-file"), ["simulate", "sim.toml", "--out", "o.nc", "--force"],
     ["o.nc: is a symbolic link"]),
    ("report-fifo-force", special("r.html", "fifo"), [*FIT, "--report", "r.html", "--force"], ["r.html: is a FIFO"]),
    ("checkpoint-fifo", special("r.h5.emcee", "fifo"), [*FIT, "--method", "emcee", "--force"],
     ["r.h5.emcee: is a FIFO"]),
    ("out-name-too-long", None, ["simulate", "sim.toml", "--out", LONG + ".nc"], ["bytes long"]),
    ("md-report-name-too-long", None, [*FIT, "--report", LONG[:215] + ".md"], ["--report", "bytes long"]),
    ("fit-many-empty-folder", lambda w: (w / "empty").mkdir(),
     ["fit-many", "empty", "--scene", "rig.toml", "--out", "fleet", "--workers", "0"], ["empty"]),
    ("fit-many-out-is-a-file", lambda w: (w / "fleet").write_text("not a folder"),
     ["fit-many", "data.csv", "--scene", "rig.toml", "--out", "fleet", "--workers", "0"], ["fleet"]),
]
ATTACKS += HOSTILE_FILES

# address space a refused command may add to the test process: a reader whose memory followed a
# declared, compressed or quadratic size would end in MemoryError (exit 1) under it
MEMORY_CEILING = 1536 << 20


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copy(RIG, tmp_path / "data.csv")
    shutil.copy(RIG_SCENE, tmp_path / "rig.toml")
    shutil.copy(SIM, tmp_path / "sim.toml")
    shutil.copy(UNIT_SCENE, tmp_path / "unit.toml")
    shutil.copy(TS_SCENE, tmp_path / "ts.toml")
    (tmp_path / "u.csv").write_text("swing,notches\n0,60\n4,41\n8,33\n12,30\n")
    return tmp_path


@pytest.mark.parametrize("name, setup, args, fragments", ATTACKS, ids=[a[0] for a in ATTACKS])
def test_an_attack_is_refused_in_one_line_and_changes_nothing(work, name, setup, args, fragments):
    if setup is not None:
        setup(work)
    before = snapshot(work)
    with memory_ceiling(MEMORY_CEILING):
        r = run(*args)
    lines = r.stderr.strip().splitlines()
    assert r.exit_code == 2, (r.exit_code, r.stderr[-2000:], r.stdout[-500:])
    assert len(lines) == 1, r.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    assert snapshot(work) == before, "a refused command changed the folder"


def test_the_attack_has_at_least_forty_classes():
    assert len({a[0] for a in ATTACKS}) == len(ATTACKS) >= 40


def test_the_console_shows_escfit_lines_only(work):
    """Third-party warnings (arviz, h5netcdf, matplotlib) and log records stay off the console of
    a short sampler run (too short for ArviZ's liking) with a Markdown report, and a summary of
    it: every stderr line is escfit's own."""
    import subprocess
    import sys

    from .conftest import ROOT

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("PYTHONWARNINGS", None)
    main = "from escfit.cli.main import main; main()"
    for args in (["fit", "data.csv", "--scene", "rig.toml", "--method", "emcee", "--walkers", "10", "--steps", "10",
                  "--out", "e.h5", "--report", "e.md", "--quiet"], ["summary", "e.h5"]):
        r = subprocess.run([sys.executable, "-c", main, *args], capture_output=True, text=True, env=env, cwd=work,
                           timeout=600)
        assert r.returncode == 0, r.stderr
        foreign = [line for line in r.stderr.splitlines()
                   if line.strip() and not line.startswith(("escfit", "warning:", "note:", "emcee:"))]
        assert not foreign, foreign


def test_control_characters_of_a_scene_title_are_shown_not_sent(work):
    """A scene title holding an escape sequence and a NUL reaches the Markdown report as visible
    escapes, never as raw control characters (a terminal or renderer would act on them)."""
    text = (work / "ts.toml").read_text()
    title = text[text.index("title = "):].splitlines()[0]
    (work / "ts.toml").write_text(text.replace(title, 'title = "bad\\u001b[31mred\\u0000end"', 1))
    shutil.copy(TS, work / "ts.csv")
    r = run("fit", "ts.csv", "--scene", "ts.toml", "--out", "r.h5", "--report", "r.md")
    assert r.exit_code == 0, r.output
    text = (work / "r.md").read_text()
    assert "bad\\x1b[31mred\\x00end" in text
    assert not any(ord(c) < 32 and c not in "\n\t" for c in text)


def test_a_full_standard_output_is_one_line_and_exit_2(work):
    """``escfit simulate ... > /dev/full``: one line naming the cause, not an internal error."""
    import subprocess
    import sys

    from .conftest import ROOT

    with open("/dev/full", "w") as full:
        r = subprocess.run([sys.executable, "-c", "from escfit.cli.main import main; main()", "simulate", "sim.toml"],
                           stdout=full, stderr=subprocess.PIPE, text=True, cwd=work,
                           env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=300)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == ["escfit: error: cannot write the command's output (No space left on device)"]
