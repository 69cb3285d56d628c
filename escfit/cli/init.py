"""``escfit init DATA``: write a commented starter scene that fits a recording.

The record is read as ``escfit fit`` reads it; what the scene needs (the period, the decay, the
columns, the noise) is measured from it (:mod:`escfit.balance.starter`), and the scene is
checked by parsing it before it is written, atomically, never over an existing file without
``--force``.  Whether the oscillator is a gravity pendulum or a spring is the user's to say
(``--pendulum`` / ``--spring``); on a terminal the command asks, elsewhere it says which it
assumed and how to change it.

``escfit fit DATA`` without a scene calls :func:`offer_starter`: on a terminal it offers to
write the starter scene and go on with it; elsewhere it says, in one line, to run ``escfit init``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

__all__ = ["init", "offer_starter", "write_starter", "interactive"]

RECORDING_OPTIONS = ("time_column", "time_unit", "sample_rate", "angle_column", "angle_unit", "counts_per_turn", "scale", "start",
                     "stop", "release", "readings", "velocity_column", "velocity_unit", "displacement_column",
                     "displacement_unit", "run", "mode")


def interactive() -> bool:
    """Whether a person is at a terminal on both ends (questions may be asked)."""
    try:
        return sys.stdin.isatty() and sys.stdout.isatty()
    except (AttributeError, ValueError):  # closed or replaced streams
        return False


def default_scene_path(data: str | Path) -> Path:
    """``<data stem>.toml`` in the current folder (``<stem>_scene.toml`` if that would be the data)."""
    stem = Path(data).stem or "scene"
    out = Path(f"{stem}.toml")
    return Path(f"{stem}_scene.toml") if out.resolve() == Path(data).resolve() else out


def _column(text):
    return int(text) if isinstance(text, str) and text.strip().isdigit() else text


def recording_table(**given) -> dict:
    """Command-line reading options as ``[recording]`` table entries (scene keys and values)."""
    table = {}
    for key in RECORDING_OPTIONS:
        value = given.get(key)
        if value is not None:
            table[key] = _column(value) if key.endswith("_column") else value
    return table


def _restoring(kind: str | None) -> tuple[str, str]:
    """``(restoring, how it was chosen)``: the flag, an answer on a terminal, or the assumption."""
    if kind:
        return kind, f"--{kind}"
    if interactive():
        answer = click.prompt("Is the oscillator a gravity pendulum, or does a spring or torsion wire restore it?",
                              type=click.Choice(["pendulum", "spring"]), default="spring")
        return answer, "your answer"
    return "spring", "assumed"


def write_starter(data: str, out: str | Path, *, kind: str | None = None, force: bool = False,
                  recording: dict | None = None, fmt: str | None = None) -> tuple[Path, list[str]]:
    """Measure the record, write the starter scene atomically and return ``(path, lines to print)``.

    Raises
    ------
    EscfitError
        An unreadable record (one line naming the option to give), an existing ``out``
        without ``force``, an output that is the data, or a folder that cannot take it.
    """
    from ..balance.starter_text import starter_scene
    from ..core.atomic import atomic_path, check_output_folder, refuse_clobbering_inputs, refuse_existing
    from ..core.errors import DataError
    from ..core.scene import load_scene
    from shlex import quote

    out = Path(out)
    if not Path(data).is_file():
        raise DataError("data file not found", str(data))
    refuse_clobbering_inputs({"--out": out}, {"data": data})
    check_output_folder(out, "--out")
    refuse_existing(out, force)
    restoring, said = _restoring(kind)
    text, summary, s = starter_scene(data, restoring=restoring, recording=recording, fmt=fmt, restoring_said=said)
    if s.quantity == "displacement":
        said = "a displacement"
    load_scene(str(out), text=text)  # the scene must parse before it is written
    with atomic_path(out, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    lines = list(summary)
    if said == "a displacement":
        lines.append("a linear oscillator (a mass on a spring): the record is a displacement in m")
    elif said == "assumed":
        lines.append("assumed a spring (linear restoring torque: a balance spring, a torsion wire); for a gravity "
                     f"pendulum run: escfit init {quote(str(data))} --pendulum --force"
                     + (f" --out {quote(str(out))}" if out != default_scene_path(data) else ""))
    else:
        lines.append(f"restoring torque: {'gravity pendulum' if restoring == 'pendulum' else 'spring (linear)'} ({said})")
    lines.append(f"wrote {out}")
    return out, lines


def unused_outputs(stem: str, folder: Path = Path(".")) -> tuple[Path, Path]:
    """``(<stem>_fit.h5, <stem>.html)`` in ``folder``, numbered ``_2``, ``_3`` ... until neither exists
    (nor the results' sampler checkpoint), so that a suggested fit refuses nothing."""
    for n in range(1, 10_000):
        tail = "" if n == 1 else f"_{n}"
        results, report = folder / f"{stem}{tail}_fit.h5", folder / f"{stem}{tail}.html"
        if not any(p.exists() for p in (results, report, Path(f"{results}.emcee"))):
            return results, report
    raise RuntimeError(f"no free name for the results of {stem} in {folder}")  # 10,000 earlier fits


def next_command(data: str, scene: Path) -> str:
    """The fit to run next, as a line a shell takes as it is: every path quoted (shlex), results
    and report named after the scene and not clashing with files in the current folder."""
    from shlex import quote

    results, report = unused_outputs(Path(scene).stem or "scene")
    return (f"escfit fit {quote(str(data))} --scene {quote(str(scene))} --out {quote(str(results))} "
            f"--report {quote(str(report))}")


@click.command("init")
@click.argument("data", type=click.Path(dir_okay=False))
@click.option("--out", type=click.Path(dir_okay=False), default=None,
              help="Scene file to write (default: DATA's name with .toml, in the current folder).")
@click.option("--pendulum", "kind", flag_value="pendulum", default=None,
              help="A gravity pendulum: torque omega0^2 sin(theta).")
@click.option("--spring", "kind", flag_value="spring", help="A spring or torsion wire: linear restoring torque.")
@click.option("--force", is_flag=True, help="Replace an existing scene file.")
@click.option("--format", "fmt", default=None,
              help="Recording format (detected from the file's content): escfit's own, raw, or an instrument's or "
                   "program's (phyphox, cassy, lvm, tracker, ...: see docs/recordings.md).")
@click.option("--time-column", default=None, help="[recording] time_column: name or 1-based position.")
@click.option("--time-unit", default=None, help="[recording] time_unit: s, ms, us, min (the header names none, or the "
                                                 "wrong one).")
@click.option("--sample-rate", default=None, help="[recording] sample_rate, e.g. '500 Hz' (instead of a time column).")
@click.option("--angle-column", default=None, help="[recording] angle_column: name or 1-based position.")
@click.option("--angle-unit", default=None, help="[recording] angle_unit: deg, rad, ... or counts.")
@click.option("--counts-per-turn", type=float, default=None, help="[recording] counts_per_turn (with counts).")
@click.option("--scale", type=float, default=None, help="[recording] scale: multiplies the raw readings.")
@click.option("--start", "start", default=None,
              help="[recording] start: the free decay starts at the first turning point from here, e.g. '13 s' "
                   "(after the record's first sample; 'abs 1407000013 s' on the file's own clock).")
@click.option("--stop", "stop", default=None, help="[recording] stop: end of the window, e.g. '60 s'.")
@click.option("--release", "release", default=None,
              help="[recording] release: the model is released here (a turning point or the end of a hold).")
@click.option("--readings", type=click.Choice(["samples", "amplitudes"]), default=None,
              help="[recording] readings: 'amplitudes' for a table of one amplitude per row (a peak per period "
                   "or per half swing) instead of samples in time.")
@click.option("--velocity-column", default=None,
              help="[recording] velocity_column: the column of an angular velocity (a gyroscope, a velocity pickup).")
@click.option("--velocity-unit", default=None, help="[recording] velocity_unit: rad/s, deg/s, rpm, or V with --scale.")
@click.option("--displacement-column", default=None,
              help="[recording] displacement_column: the column of a linear displacement (a motion detector).")
@click.option("--displacement-unit", default=None, help="[recording] displacement_unit: m, cm, mm, or V with --scale.")
@click.option("--run", type=click.IntRange(min=1), default=None,
              help="[recording] run: which run (from 1) of a file holding several side by side (Vernier, PASCO, CASSY).")
@click.option("--mode", type=click.IntRange(min=1, max=2), default=None,
              help="[recording] mode: of a record ringing in two modes, fit the slower (1, the default) or the "
                   "faster (2); the other is filtered out.")
def init(data, out, kind, force, fmt, **options):
    """Write a starter scene that fits DATA (a recording of your own), and say what to run next.

    The period, the decay and the columns are measured from the record; options the record
    cannot settle (which column, its unit, a clock) are written in a [recording] table.
    """
    from ..analysis.recordings.formats_list import FORMAT_NAMES
    from ..core.errors import DataError
    from ..core.inputs import check_input_file

    check_input_file(data, "data")  # a FIFO or a device is named, not reported missing (nor read)
    if fmt is not None and fmt not in FORMAT_NAMES:
        raise DataError(f"--format {fmt!r} is not a balance recording format; known: {', '.join(FORMAT_NAMES)}", data)
    out = Path(out) if out else default_scene_path(data)
    written, lines = write_starter(data, out, kind=kind, force=force, recording=recording_table(**options), fmt=fmt)
    for line in lines:
        click.echo(line)
    click.echo(f"next: {next_command(data, written)}")


def offer_starter(data: str, recording: dict | None = None, fmt: str | None = None) -> str:
    """``escfit fit DATA`` without a scene: on a terminal, offer a starter scene; else say how to make one.

    Returns
    -------
    str
        The scene written (the fit goes on with it).

    Raises
    ------
    SceneError
        Not on a terminal, or the offer declined: one line naming ``escfit init``.
    """
    from ..core.errors import SceneError

    from shlex import quote

    out = default_scene_path(data)
    command = f"escfit init {quote(data)}" + ("" if out == Path(f"{Path(data).stem}.toml") else f" --out {quote(str(out))}")
    if not interactive():
        raise SceneError(f"no scene given: write a starter scene with `{command}` (or give --scene SCENE.toml, or a "
                         "fit recipe)", data)
    if out.exists():
        raise SceneError(f"no scene given; {out} exists: fit with `escfit fit {quote(data)} --scene {quote(str(out))}`",
                         data)
    if not click.confirm(f"No scene given. Write a starter scene for {Path(data).name} to {out} and fit with it?",
                         default=True):
        raise SceneError(f"no scene given: write one with `{command}`, or give --scene SCENE.toml", data)
    written, lines = write_starter(data, out, recording=recording, fmt=fmt)
    for line in lines:
        click.echo(line)
    click.echo(f"fitting with {written} (next time: escfit fit {quote(data)} --scene {quote(str(written))})")
    return str(written)
