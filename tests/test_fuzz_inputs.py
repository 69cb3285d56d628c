"""Property-based fuzz of the scene parser and every recording reader.

Each case mutates a shipped file (a scene value replaced by a hostile one; a data file with a
flipped byte, a dropped or doubled line, a hostile field, a byte-order mark, latin-1 bytes or a
truncation) and runs the parser or reader in this process under a time limit and an address-space
limit.  The promise checked: the input is read or refused with escfit's own error (the CLI's exit
2), never another exception (exit 1), never a hang and never a runaway allocation; the input file
is never changed.  The budget (examples per test) is bounded so the suite stays fast; set
``ESCFIT_FUZZ_EXAMPLES`` for a longer hunt.
"""

from __future__ import annotations

import os
import re
import resource
import signal
from contextlib import contextmanager
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from escfit.core.errors import EscfitError

ROOT = Path(__file__).resolve().parents[1]
DATASETS = ROOT / "datasets"
EXAMPLES = int(os.environ.get("ESCFIT_FUZZ_EXAMPLES", "60"))
CASE_SECONDS = 20
MEMORY_HEADROOM = 3 << 30  # bytes of address space a case may add to the process's


class Hang(Exception):
    pass


@contextmanager
def bounded(seconds: int = CASE_SECONDS):
    """Run the body with an alarm after ``seconds`` and an address-space limit (MemoryError)."""
    def ring(signum, frame):
        raise Hang(f"no answer after {seconds} s")

    old_handler = signal.signal(signal.SIGALRM, ring)
    with memory_ceiling(MEMORY_HEADROOM):
        signal.alarm(seconds)
        try:
            yield
        finally:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, old_handler)


@contextmanager
def memory_ceiling(extra: int):
    """Run the body with at most ``extra`` bytes of address space above the process's own."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    used = address_space()
    limit = used + extra if used else resource.RLIM_INFINITY
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def address_space() -> int:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _outcome(call):
    """'ok', or 'refused: <message>'; anything else fails the test with the exception."""
    try:
        with bounded():
            call()
        return "ok"
    except EscfitError as exc:
        text = str(exc)
        assert "\n" not in text.strip(), f"error message is not one line: {text!r}"
        return f"refused: {text}"


# --------------------------------------------------------------------------- scenes

SCENES = sorted(
    [p for p in (DATASETS / "scenes").glob("*.toml")]
    + [DATASETS / "recordings" / n for n in ("pulses_scene.toml", "timegrapher_scene.toml", "timeseries_scene.toml")]
    + [DATASETS / "geneva" / "four_pin.toml", DATASETS / "verge" / "m739.toml", DATASETS / "friction" / "monday1965_rig.toml"]
    + sorted((DATASETS / "real" / "scenes").glob("*.toml")))

HOSTILE_VALUES = [
    "0", "-1", "1e308", "-1e308", "1e-300", "nan", "inf", "-inf", "300", "1e19", "9223372036854775807",
    '"9**9**9 rad"', '"1e400 rad"', '"300 deg"', '"1 m"', '""', '"abc"', "true", "[]", "{}", '"10 s**9**9"',
    '"\u202e rad"', '"-1e12"', "[1, 2, 3]", '{ value = 1, vary = true, min = 5, max = 1 }',
    '{ value = 1, vary = true, prior = "normal(0, -1)" }', '{ value = 1, vary = true, prior = "uniform(nan, 1)" }',
    '{ value = 1, vary = true, prior = "__import__(\'os\')" }', '"0.5 rad / s ** 99"',
]
_ASSIGNMENT = re.compile(r"^(\s*[A-Za-z_][\w.]*\s*=\s*)(.+?)\s*$", re.M)


def _scene_mutant(text: str, which: int, value: str) -> str:
    spots = list(_ASSIGNMENT.finditer(text))
    m = spots[which % len(spots)]
    return text[:m.start(2)] + value + text[m.end(2):]


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck))
@given(scene=st.sampled_from(SCENES), which=st.integers(0, 200), value=st.sampled_from(HOSTILE_VALUES))
def test_scene_parser_reads_or_refuses(scene, which, value):
    from escfit import load_scene

    before = scene.read_bytes()
    text = _scene_mutant(scene.read_text(encoding="utf-8"), which, value)

    def run():
        sc = load_scene(str(scene), text=text)
        if sc.model == "balance":
            from escfit.balance import solve

            solve(sc, swings=6)

    _outcome(run)
    assert scene.read_bytes() == before


# --------------------------------------------------------------------------- recordings

def _balance_reader(path):
    from escfit.analysis.recordings.detect import read_recording

    return read_recording(path)


def _format_reader(spec=None):
    """An instrument's or program's file read with the scene's [recording] options."""
    def read(path):
        from escfit.analysis.recordings.detect import read_with_spec

        return read_with_spec(path, spec)
    return read


def _friction_reader(path):
    from escfit.friction.readers import read_readings

    return read_readings(path)


def _geneva_reader(path):
    from escfit.geneva.data import read_data

    return read_data(path)


def _verge_reader(path):
    from escfit.verge.data import read_turns_csv

    return read_turns_csv(path)


DATA = [
    (DATASETS / "recordings" / "monday_pulses.csv", _balance_reader),
    (DATASETS / "recordings" / "monday_timegrapher.json", _balance_reader),
    (DATASETS / "recordings" / "monday_timegrapher_beats.csv", _balance_reader),
    (DATASETS / "recordings" / "monday_timeseries.csv", _balance_reader),
    (DATASETS / "recordings" / "tg_applog_example.csv", _balance_reader),
    (DATASETS / "real" / "string_pendulum_video" / "lab1_data.txt", _balance_reader),
    (DATASETS / "friction" / "monday1965_session_1095_steel.csv", _friction_reader),
    (DATASETS / "geneva" / "meyer1973_four_pin.csv", _geneva_reader),
    (DATASETS / "geneva" / "synthetic_four_pin_trace.csv", _geneva_reader),
    (DATASETS / "verge" / "m739_output_turns.csv", _verge_reader),
] + [(p, _balance_reader) for p in sorted((DATASETS / "monday1965" / "synthetic").glob("*.csv"))[:2]]


def _format_specs():
    import math

    from escfit.analysis.recordings.recording_spec import RecordingSpec

    special = {"arduino_serial.txt": RecordingSpec(angle_unit="deg"), "phyphox_gyroscope.csv": RecordingSpec(
        velocity_column=2), "timegrapher_slices.csv": RecordingSpec(bph=28800, lift_angle=math.radians(52.0))}
    folder = DATASETS / "recordings" / "formats"
    return [(p, _format_reader(special.get(p.name))) for p in sorted(folder.iterdir()) if p.suffix != ".py"] + \
        [(DATASETS / "real" / "pohl_heilaut" / "raw" / "Dämpfung.trk", _format_reader())]


DATA += _format_specs()

HOSTILE_FIELDS = ["1e400", "nan", "inf", "-1e12", "1000000000", "1e19", "10" * 200, "load_g**9**9**9", '"', "",
                  "\x00", "9" * 5000, "9" * 200_000, "-0", "1,5", "\u00b0", "[[[[[[[[[[" * 200, "1" + "0" * 400,
                  "notch_deg: inf", "release_sample: -1e12", "Position(deg**9**9)"]


@st.composite
def mutated_bytes(draw):
    path, reader = draw(st.sampled_from(DATA))
    raw = path.read_bytes()
    lines = raw.split(b"\n")
    kind = draw(st.sampled_from(["flip", "drop", "double", "field", "bom", "latin1", "truncate", "swap"]))
    pick = draw(st.integers(0, 10**6))
    if kind == "flip":
        out = bytearray(raw)
        out[pick % len(out)] ^= 1 << draw(st.integers(0, 7))
        out = bytes(out)
    elif kind == "drop":
        out = b"\n".join(lines[:pick % len(lines)] + lines[pick % len(lines) + 1:])
    elif kind == "double":
        i = pick % len(lines)
        out = b"\n".join(lines[:i + 1] + lines[i:])
    elif kind == "field":
        i = pick % len(lines)
        value = draw(st.sampled_from(HOSTILE_FIELDS)).encode("utf-8")
        parts = re.split(rb"([,;\t: ]+)", lines[i])
        numbers = [k for k, p in enumerate(parts) if re.fullmatch(rb"[-+0-9.eE]+|[A-Za-z_]\w*", p)]
        if numbers:
            parts[numbers[draw(st.integers(0, len(numbers) - 1))]] = value
        lines[i] = b"".join(parts)
        out = b"\n".join(lines)
    elif kind == "bom":
        out = b"\xef\xbb\xbf" + raw
    elif kind == "latin1":
        out = raw.decode("utf-8", "replace").replace("s", "\u00b5s", 1).encode("latin-1", "replace")
    elif kind == "truncate":
        out = raw[:pick % len(raw)]
    else:
        i, j = pick % len(lines), (pick // 7) % len(lines)
        lines[i], lines[j] = lines[j], lines[i]
        out = b"\n".join(lines)
    return path, reader, kind, out


@settings(max_examples=EXAMPLES * 2, deadline=None, suppress_health_check=list(HealthCheck))
@given(case=mutated_bytes())
def test_readers_read_or_refuse(tmp_path_factory, case):
    path, reader, kind, data = case
    work = tmp_path_factory.mktemp("fuzz")
    target = work / path.name
    target.write_bytes(data)
    before = path.read_bytes()
    _outcome(lambda: reader(target))
    assert target.read_bytes() == data, "a reader changed its input"
    assert path.read_bytes() == before
    assert sorted(p.name for p in work.iterdir()) == [path.name], "a reader left a file beside its input"
