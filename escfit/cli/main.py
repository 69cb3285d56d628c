"""The ``escfit`` command line.

Exit status: 0 on success, 2 on bad input or usage (one line naming the file, key or value),
3 when ``escfit fit`` ran but determined nothing (the table is printed under "NOT DETERMINED"
and the results file written, so that it can be inspected; see
:func:`escfit.inference.reconcile.verdict`), 1 on an internal error, 130 when interrupted (Ctrl-C) and 141 (128 + SIGPIPE, as the shell
tools give) when the reader of the output went away, as ``head`` does: that exit is quiet.
Output files are written atomically, readable as the umask allows, and never replaced
without ``--force``.  Before any work, every output path is checked: one that is an input
(data, scene, recipe, results) or another output of the same command is refused, ``--force``
or not, as is one whose folder is missing, not a folder or not writable.

Third-party libraries' warnings (lmfit, numpy inside lmfit, arviz, xarray, dask, ...) are kept
off the console unless ``--debug`` is given or ``PYTHONWARNINGS`` / ``-W`` asks for them;
escfit's own warnings are shown.  Only click and escfit's errors and version are imported
before a command runs, so that ``escfit -h`` answers at once.
"""

from __future__ import annotations

import errno
import json
import os
import sys
import traceback
import warnings
from pathlib import Path

from . import process  # noqa: F401,E402 - one BLAS thread, the collector's thresholds: before numpy loads

import click  # noqa: E402

from ..core.version import __version__
from ..core.errors import EscfitError
from .options import STEPS_MAX, WALKERS_MAX, FiniteFloat, MethodType, StepsType
from ..core.interrupts import interrupting_signals
from ..core.unused import leave_out, unused_by

__all__ = ["main", "cli"]


# Commands that live beside the features they drive, imported only when used.
LAZY_COMMANDS = {
    "bench": "escfit.cli.bench:bench",
    "compare": "escfit.cli.compare:compare",
    "fit-many": "escfit.cli.study:fit_many",
    "examples": "escfit.cli.examples:examples",
    "summary": "escfit.cli.summary:summary",
    "init": "escfit.cli.init:init",
}

EXIT_NOT_DETERMINED = 3  # a fit ran but its parameters are not determined
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE: what a shell reports for `yes | head -1`
SEED_MAX = 2**32 - 1  # numpy's RandomState takes seeds in [0, 2**32)

# Modules whose warnings are kept off the console (see :func:`quiet_third_party_warnings`)
THIRD_PARTY = ("lmfit", "numpy", "scipy", "arviz", "xarray", "dask", "distributed", "h5netcdf", "h5py", "emcee",
               "numba", "pint", "matplotlib", "pandas", "tqdm", "jinja2", "asteval", "uncertainties")

CONTEXT_SETTINGS = {"help_option_names": ["-h", "--help"]}
# The finest notch a recorder's scale can carry, deg: below it counts of a swing exceed 10**6
# and a mistyped value (1e-300) would be blamed on the data
NOTCH_MIN_DEG = 0.01


def quiet_third_party_warnings(argv: list[str] | None = None) -> bool:
    """Ignore warnings raised from third-party modules, unless asked for them.

    Parameters
    ----------
    argv
        The command line (default ``sys.argv[1:]``): ``--debug`` keeps every warning.

    Returns
    -------
    bool
        Whether filters were installed (not when ``--debug``, ``-W`` or ``PYTHONWARNINGS``
        chose otherwise).
    """
    argv = sys.argv[1:] if argv is None else argv
    if "--debug" in argv or sys.warnoptions or os.environ.get("PYTHONWARNINGS"):
        return False
    for module in THIRD_PARTY:
        # a warning is attributed to the module of the frame it points at: numpy's
        # RuntimeWarning in lmfit's code counts as lmfit's, one in escfit's code stays shown
        warnings.filterwarnings("ignore", module=rf"{module}(\.|$)")
    warnings.filterwarnings("ignore", category=FutureWarning, message=r"(?i).*arviz")
    return True


def _quiet_broken_pipe(status: int = EXIT_BROKEN_PIPE) -> None:
    """The reader of stdout has gone (``escfit summary X.h5 | head``) or stdout is full: leave quietly.

    stdout is pointed at the null device so that the interpreter's last flush cannot fail
    again, then the command exits with ``status`` (:data:`EXIT_BROKEN_PIPE` by default).
    """
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no file descriptor behind stdout (tests): nothing to protect
        pass
    raise click.exceptions.Exit(status)


class _Group(click.Group):
    """Maps escfit's errors to exit status 2 and anything unexpected to 1; loads lazy commands."""

    def list_commands(self, ctx):
        import importlib.util

        def exists(module: str) -> bool:
            try:
                return importlib.util.find_spec(module) is not None
            except ModuleNotFoundError:  # a missing parent package
                return False

        present = {n for n, target in LAZY_COMMANDS.items() if exists(target.split(":")[0])}
        return sorted({*super().list_commands(ctx), *present})

    def get_command(self, ctx, name):
        cmd = super().get_command(ctx, name)
        if cmd is None and name in LAZY_COMMANDS:
            import importlib

            module, attr = LAZY_COMMANDS[name].split(":")
            try:
                cmd = getattr(importlib.import_module(module), attr)
            except (ImportError, AttributeError) as exc:
                raise click.UsageError(f"command {name!r} is not available ({exc})") from None
        return cmd

    def make_context(self, info_name, args, parent=None, **extra):
        try:  # --help and --version print while the arguments are parsed
            return super().make_context(info_name, args, parent=parent, **extra)
        except BrokenPipeError:
            _quiet_broken_pipe()

    def invoke(self, ctx):
        try:
            with interrupting_signals():  # SIGTERM, SIGHUP, SIGQUIT end a command as Ctrl-C does
                return super().invoke(ctx)
        except EscfitError as exc:
            click.echo(f"escfit: error: {exc}", err=True)
            ctx.exit(2)
        except click.UsageError as exc:  # one line, as every other refusal
            where = exc.ctx.command_path if exc.ctx is not None else "escfit"
            click.echo(f"escfit: error: {exc.format_message()} (see '{where} -h')", err=True)
            ctx.exit(exc.exit_code)
        except (click.exceptions.Exit, click.ClickException, click.exceptions.Abort):
            raise
        except BrokenPipeError:
            _quiet_broken_pipe()
        except OSError as exc:
            if exc.errno not in (errno.ENOSPC, errno.EDQUOT, errno.EIO):
                raise
            # the output files are written whole or not at all; this is the console itself (> /dev/full)
            click.echo(f"escfit: error: cannot write the command's output ({exc.strerror})", err=True)
            _quiet_broken_pipe(2)
        except KeyboardInterrupt:  # commands with something to resume say so themselves
            click.echo("escfit: interrupted", err=True)
            ctx.exit(EXIT_INTERRUPTED)
        except Exception as exc:  # noqa: BLE001 - the last line of defence of a CLI
            click.echo(f"escfit: internal error: {type(exc).__name__}: {exc}", err=True)
            if "--debug" in sys.argv:
                traceback.print_exc()
            ctx.exit(1)


@click.group(cls=_Group, context_settings=CONTEXT_SETTINGS)
@click.version_option(__version__, prog_name="escfit")
@click.option("--debug", is_flag=True, help="Print the traceback of an internal error; show third-party warnings.")
def cli(debug) -> None:
    """Identify the physical parameters of mechanical timekeeping oscillators.

    New here?  `escfit init DATA` writes a starter scene that fits a recording of your own;
    `escfit examples DIR` copies example recordings, scenes and fit recipes into DIR and
    prints what to run next.
    """


@cli.command()
@click.argument("scene", type=click.Path(dir_okay=False))
@click.option("--solver", default=None,
              help="Solver: balance exact (default; dop853 for a pendulum) | dop853 | rk4 | ivp; "
                   "geneva dop853 (default) | rk4; see the README.")
@click.option("--swings", type=click.IntRange(1), default=None, help="Half swings (overrides the scene).")
@click.option("--h", "step", type=FiniteFloat(0.0, low_open=True, unit="s"), default=None, help="RK4 step size, s.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with the results.")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="Write the dataset to FILE.nc (HDF5).")
@click.option("--force", is_flag=True, help="Replace an existing --out file.")
@click.option("--recorder", type=click.Choice(["unit-curve", "pulses", "timegrapher", "timeseries"]), default=None,
              help="Write a synthetic recording of a balance scene to --out instead of the dataset "
                   "(timegrapher: tg JSON, or the per-beat CSV when --out ends in .csv).")
@click.option("--noise", type=FiniteFloat(0.0), default=None,
              help="The recorder's noise sd: reading (rad), pulse timing (s), timegrapher amplitude (deg) "
                   "or sample (rad); each recorder's default if omitted.")
@click.option("--seed", type=click.IntRange(0, SEED_MAX), default=0, show_default=True,
              help="Seed of the recorder's noise.")
@click.option("--notch-deg", type=FiniteFloat(NOTCH_MIN_DEG, 360.0, high_open=True, unit="deg"), default=None,
              help="unit-curve recorder: count notches of this angle (deg) instead of amplitudes.")
@click.option("--notch-reading", type=click.Choice(["counted", "nearest"]), default=None,
              help="unit-curve recorder with --notch-deg: marks passed (counted, the default) or the mark "
                   "nearest the turning point.")
def simulate(scene, solver, swings, step, as_json, out, force, recorder, noise, seed, notch_deg, notch_reading):
    """Simulate SCENE (a TOML scene file), or record it with a synthetic recorder."""
    from ..core.atomic import refuse_existing
    from ..core.h5write import write_netcdf
    from ..core.family import get_family
    from ..core.scene import load_scene

    if out:
        _check_outputs({"--out": out}, {"scene": scene})
        refuse_existing(out, force)
    sc = load_scene(scene)
    family = get_family(sc.model)
    if recorder is not None:
        _record(sc, recorder, out, force=force, noise=noise, seed=seed, swings=swings, notch_deg=notch_deg,
                notch_reading=notch_reading)
        return
    options = {}
    if swings is not None:
        options["swings"] = swings
    if step is not None:
        options["h"] = step
    ds = family.simulate(sc, solver, **options)
    if out:
        write_netcdf(ds, out, force=force)  # built in memory: a full disk is one error line, no partial file
    if as_json:
        from .summary import json_safe

        click.echo(json.dumps(json_safe(family.json_summary(ds))))
    else:
        click.echo("\n".join([f"{Path(sc.where).name}: model {sc.model}, status {ds.attrs.get('status')}",
                              *family.describe(ds)]))


def _record(sc, recorder: str, out: str | None, *, force: bool, noise, seed: int, swings, notch_deg,
            notch_reading=None) -> None:
    """``simulate --recorder``: one synthetic recording, written atomically."""
    from ..core.atomic import atomic_path
    from ..core.errors import SceneError
    from ..core.family import family_names, get_family

    family = get_family(sc.model)
    if recorder not in family.recorders:
        takers = [n for n in family_names() if recorder in get_family(n).recorders]
        raise SceneError(f"--recorder {recorder} records {' and '.join(takers)} scenes; this scene's model is "
                         f"{sc.model!r}", sc.where)
    if not out:
        raise SceneError("--recorder needs --out FILE for the recording", sc.where)
    options = {} if swings is None else {"swings": swings}
    if notch_deg is not None:
        if recorder != "unit-curve":
            raise SceneError("--notch-deg applies to the unit-curve recorder only", sc.where)
        options["notch_deg"] = notch_deg
    if notch_reading is not None:
        if notch_deg is None:
            raise SceneError("--notch-reading applies to notch counts: give --notch-deg too", sc.where)
        options["notch_reading"] = notch_reading
    if recorder == "timegrapher":
        options["fmt"] = "csv" if str(out).lower().endswith(".csv") else "json"
    with atomic_path(out, force=force) as tmp:
        family.record(sc, recorder, tmp, noise=noise, seed=seed, **options)
    click.echo(f"wrote {out} ({recorder}, seed {seed})")


@cli.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="charts", show_default=True,
              help="Directory for the CSV and PNG files.")
@click.option("--c-over-omega0", "c0", type=FiniteFloat(0.0, 1.99), default=0.05, show_default=True,
              help="Damping ratio at which the conversion charts are drawn.")
@click.option("--no-png", is_flag=True, help="CSV only (no matplotlib needed).")
@click.option("--force", is_flag=True, help="Replace existing files.")
def charts(out_dir, c0, no_png, force):
    """Regenerate Monday's charts by computation: unit curves, conversion charts, factors."""
    from ..balance.monday.charts import graph_factor
    from ..balance.monday.chart_files import write_charts

    files = write_charts(out_dir, c_over_w0=c0, force=force, png=not no_png)
    for f in files:
        click.echo(str(f))
    click.echo(f"graph factor K/K_R at C/omega0 = {c0:g}: {graph_factor(c0):.4f}")


# Bytes a Markdown report's figure files add to its stem (``<stem>_<figure>.png``; the longest
# figure names are about 25 characters)
REPORT_FIGURE_NAMES = 48


def _check_outputs(outputs: dict, inputs: dict, companions: dict | None = None) -> None:
    """Refuse, before any work, outputs that are inputs or each other, or whose folder cannot take them."""
    from ..core.atomic import check_output_folder, refuse_clobbering_inputs, refuse_existing

    refuse_clobbering_inputs(outputs, inputs)
    for role, path in outputs.items():
        if path is not None:
            check_output_folder(path, role, companions=(companions or {}).get(role, 0))
            refuse_existing(path, force=True)  # a device, FIFO, socket or link is never replaced


RECIPE_KEYS = {"data", "scene", "method", "out", "seed", "walkers", "steps", "max_steps", "burn", "unit", "material",
               "format", "notch_deg", "report", "title", "solver", "moves"}


def _recipe_steps(recipe: dict, key: str, where: str):
    """A recipe's ``steps``/``max_steps``, refused with the file and key named when it is not one."""
    from ..core.errors import SceneError

    value = recipe.get(key)
    ok = value is None or (key == "steps" and value == "auto") or (
        isinstance(value, int) and not isinstance(value, bool) and 10 <= value <= STEPS_MAX)
    if not ok:
        raise SceneError(f"{key} must be {'auto or ' if key == 'steps' else ''}a whole number in [10, {STEPS_MAX}], "
                         f"got {value!r}", f"{where} (recipe).{key}")
    return value


# The kind of value each recipe key takes (steps and max_steps: see _recipe_steps)
RECIPE_TEXT = ("data", "scene", "out", "report", "title", "solver", "format", "material")
RECIPE_CHOICES = {"moves": ("stretch", "de", "de-t")}
RECIPE_WHOLE = {"seed": (0, SEED_MAX), "walkers": (2, WALKERS_MAX), "burn": (0, STEPS_MAX)}


def _check_recipe_values(doc: dict, where: str) -> None:
    """Refuse a recipe value of the wrong kind, naming the file and the key."""
    from ..core.errors import SceneError

    def refuse(key, what):
        raise SceneError(f"{key} must be {what}, got {doc[key]!r}", f"{where}.{key}")

    for key in RECIPE_TEXT:
        if key in doc and (not isinstance(doc[key], str) or not doc[key].strip()):
            refuse(key, "a non-empty text")
    if "method" in doc:
        from ..inference.lmfit_path import check_method

        try:
            check_method(doc["method"]) if isinstance(doc["method"], str) else refuse("method", "a text")
        except EscfitError as exc:
            raise SceneError(str(exc), f"{where}.method") from None
    for key, choices in RECIPE_CHOICES.items():
        if key in doc and doc[key] not in choices:
            refuse(key, " or ".join(repr(c) for c in choices))
    for key, (low, high) in RECIPE_WHOLE.items():
        value = doc.get(key)
        if key in doc and (isinstance(value, bool) or not isinstance(value, int) or value < low
                           or (high is not None and value > high)):
            refuse(key, f"a whole number >= {low}" if high is None else f"a whole number in [{low}, {high}]")
    if "unit" in doc and (isinstance(doc["unit"], bool) or not isinstance(doc["unit"], (str, int))):
        refuse("unit", "a unit's name or number")
    if "notch_deg" in doc and (isinstance(doc["notch_deg"], bool) or not isinstance(doc["notch_deg"], (int, float))
                               or not NOTCH_MIN_DEG <= doc["notch_deg"] < 360):
        refuse("notch_deg", f"a number of degrees in [{NOTCH_MIN_DEG:g}, 360)")


def _read_recipe(path: Path) -> dict:
    import tomllib

    from ..core.errors import SceneError
    from ..core.scene import check_keys

    from ..core.inputs import check_input_file
    from ..core.scene import parse_toml

    check_input_file(path, "fit recipe", SceneError)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"cannot read fit recipe ({exc})", str(path)) from None
    doc = parse_toml(text, str(path))
    check_keys(doc, RECIPE_KEYS, f"{path} (recipe)", {"data", "scene"})
    _check_recipe_values(doc, f"{path} (recipe)")
    for key in ("data", "scene"):
        doc[key] = str((path.parent / doc[key]).resolve())
    return doc


@cli.command()
@click.argument("data", type=click.Path(dir_okay=False))
@click.option("--scene", "scene_path", type=click.Path(dir_okay=False), default=None, help="Scene TOML with free parameters.")
@click.option("--method", type=MethodType(), default=None,
              help="leastsq (default; a recipe may set it): scipy's trust region; emcee: then the posterior; "
                   "lmfit:NAME: least squares with lmfit's minimiser NAME (leastsq, least_squares, nelder, "
                   "differential_evolution, basinhopping, ampgo, brute, ...; needs lmfit).")
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="Results file (HDF5).")
@click.option("--seed", type=click.IntRange(0, SEED_MAX), default=None, help="Seed of the fit's random numbers.")
@click.option("--walkers", type=click.IntRange(2, WALKERS_MAX), default=None)
@click.option("--steps", type=StepsType(), default=None,
              help="emcee steps, or 'auto': sample until split R-hat <= 1.01, bulk and tail ESS >= 400 and 50 "
                   "autocorrelation times, up to --max-steps (default: the model family's; auto for balance).")
@click.option("--max-steps", type=click.IntRange(10, STEPS_MAX), default=None, help="Cap of an automatic run (default 20000).")
@click.option("--checkpoint-every", type=FiniteFloat(0.0, unit="s"), default=10.0, show_default=True,
              help="Seconds between saves of the sampler's checkpoint (<out>.emcee); longer when a save would take "
                   "over a twentieth of the run.  A kill loses the steps since the last save.")
@click.option("--burn", type=click.IntRange(0), default=None)
@click.option("--unit", "unit_id", default=None, help="Fit only this unit of a multi-unit file.")
@click.option("--material", default=None, help="friction_rig: fit only this material of a rig readings file.")
@click.option("--format", "fmt", default=None, help="Recording format (detected from the file's content; raw: a table or .mat file read "
              "with the [recording] options; phyphox, cassy, lvm, ...: an instrument's or program's file, see "
              "docs/recordings.md; speed-trace and terminal-speeds: Geneva data).")
@click.option("--time-column", default=None, help="[recording] time_column: name or 1-based position.")
@click.option("--sample-rate", default=None, help="[recording] sample_rate, e.g. '500 Hz' (instead of a time column).")
@click.option("--angle-column", default=None, help="[recording] angle_column: name or 1-based position.")
@click.option("--angle-unit", default=None, help="[recording] angle_unit: deg, rad, ... or counts.")
@click.option("--counts-per-turn", type=FiniteFloat(0.0, low_open=True), default=None, help="[recording] counts_per_turn (with counts).")
@click.option("--scale", type=FiniteFloat(), default=None, help="[recording] scale: multiplies the raw readings.")
@click.option("--start", "start_time", default=None,
              help="[recording] start: the free decay starts at the first turning point from here, e.g. '13 s' "
                   "(after the record's first sample; 'abs 1407000013 s' on the file's own clock).")
@click.option("--stop", "stop_time", default=None, help="[recording] stop: end of the window, e.g. '60 s'.")
@click.option("--release", "release_time", default=None,
              help="[recording] release: the model is released here (a turning point or the end of a hold), "
                   "e.g. '14.2 s'; no push or hold before it is looked for.")
@click.option("--solver", default=None, help="Forward solver (default: exact, or dop853 for a pendulum).")
@click.option("--moves", type=click.Choice(["stretch", "de", "de-t"]), default=None,
              help="emcee proposal: stretch, de (differential evolution: coupled parameters, one-parameter "
                   "posteriors) or de-t (Student-t independence proposals fitted to the ensemble, with de: "
                   "near-normal posteriors in fewer steps); default: the model family's.")
@click.option("--notch-deg", type=FiniteFloat(NOTCH_MIN_DEG, 360.0, high_open=True, unit="deg"), default=None,
              help="Notch angle for notch counts, deg.")
@click.option("--resume", is_flag=True, help="Continue an interrupted emcee run from its checkpoint.")
@click.option("--force", is_flag=True, help="Replace an existing results file.")
@click.option("--report", "report_path", type=click.Path(dir_okay=False), default=None, help="Also write a report.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--timings", "show_timings", is_flag=True, help="Print each phase's wall and CPU seconds on stderr.")
def fit(data, scene_path, method, out, seed, walkers, steps, max_steps, checkpoint_every, burn, unit_id, material, fmt, time_column, sample_rate,
        angle_column, angle_unit, counts_per_turn, scale, start_time, stop_time, release_time, solver, moves, notch_deg,
        resume, force, report_path, quiet, show_timings):
    """Fit DATA (a recording) with --scene SCENE, or run a fit RECIPE.toml.

    Without a scene, `escfit init DATA` writes a starter scene (on a terminal this command offers to).
    """
    from ..core import timings

    timings.reset()  # this command's phases only (several commands may run in one process)
    startup = timings.since_process_start()  # interpreter, click and the command line's own imports
    with timings.phase("imports"):
        from ..inference import fit as run_fit

    recipe: dict = {}
    recipe_path = None
    if data.endswith(".toml") and scene_path is None:
        where = recipe_path = data
        recipe = _read_recipe(Path(data))
        data, scene_path = recipe["data"], recipe["scene"]
        for key in ("steps", "max_steps"):
            _recipe_steps(recipe, key, where)
    from ..core.inputs import check_input_file

    check_input_file(data, "data")
    if scene_path is None:  # a record of one's own: offer a starter scene (on a terminal) or name `escfit init`
        from .init import offer_starter, recording_table

        from ..analysis.recordings.formats_list import FORMAT_NAMES

        fmt_raw = fmt if fmt in FORMAT_NAMES else None
        scene_path = offer_starter(data, recording_table(
            time_column=time_column, sample_rate=sample_rate, angle_column=angle_column, angle_unit=angle_unit,
            counts_per_turn=counts_per_turn, scale=scale, start=start_time, stop=stop_time, release=release_time),
            fmt_raw)
    pick = lambda cli_value, key, default: cli_value if cli_value is not None else recipe.get(key, default)  # noqa: E731
    method = pick(method, "method", "leastsq")
    out = pick(out, "out", None) or f"{Path(data).stem}_fit.h5"
    report_path = report_path or recipe.get("report")
    outputs = {"--out": out, "--report": report_path}
    if method == "emcee":
        outputs["the checkpoint (--out + .emcee)"] = f"{out}.emcee"
    # refused before any work, --force or not: an output must not replace an input or another output
    _check_outputs(outputs, {"data": data, "scene": scene_path, "recipe": recipe_path},
                   companions={"--report": REPORT_FIGURE_NAMES} if str(report_path).endswith(".md") else None)
    if report_path:
        from ..core.atomic import refuse_existing

        refuse_existing(report_path, force)
    from ..core.scene import load_scene

    with timings.phase("scene"):
        scene = load_scene(scene_path)
    from ..core.family import check_options, get_family

    options = check_options(get_family(scene.model), {
        "fmt": pick(fmt, "format", None), "notch_deg": pick(notch_deg, "notch_deg", None),
        "unit": pick(unit_id, "unit", None), "solver": pick(solver, "solver", None),
        "material": pick(material, "material", None),
        "recording": {"time_column": _column(time_column), "sample_rate": sample_rate,
                      "angle_column": _column(angle_column), "angle_unit": angle_unit,
                      "counts_per_turn": counts_per_turn, "scale": scale, "start": start_time,
                      "stop": stop_time, "release": release_time}}, FIT_FLAGS, scene_path)
    result = _run_fit_interruptible(run_fit, scene, data, method=method, out=out, force=force,
                                    seed=pick(seed, "seed", 0),
                                    walkers=pick(walkers, "walkers", None), steps=pick(steps, "steps", None),
                                    max_steps=pick(max_steps, "max_steps", None),
                                    checkpoint_every=checkpoint_every, burn=pick(burn, "burn", None),
                                    resume=resume, progress=not quiet and sys.stderr.isatty(),
                                    moves=pick(moves, "moves", None), title=recipe.get("title"), **options)
    click.echo(f"wrote {out}")
    with timings.phase("summary"):
        _print_summary(result)
    if report_path:
        with timings.phase("report"):
            _write_report(out, report_path, force, result)
    if show_timings:
        click.echo(timings.table(startup), err=True)
    if getattr(result, "verdict", "") == "not determined":
        raise click.exceptions.Exit(EXIT_NOT_DETERMINED)


def _write_report(results: str, report_path: str, force: bool, result=None) -> None:
    """The report of a fit just written (``result``, as written to ``results``); if it cannot be written,
    say that the results are kept and which command writes it from them (a rerun would find its output)."""
    from ..core.errors import ResultsError
    from ..report import make_report

    from shlex import quote

    again = (f"`escfit report {quote(str(results))} --out {quote(str(report_path))}"
             f"{' --format md' if report_path.endswith('.md') else ''}`")
    try:
        make_report(results, report_path, fmt="md" if str(report_path).endswith(".md") else "html", force=force,
                    result=result)
    except KeyboardInterrupt:
        click.echo(f"escfit: interrupted while writing the report; the results are saved in {results}: {again} "
                   "writes it", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except EscfitError as exc:
        raise ResultsError(f"the report was not written ({exc}); the results are saved in {results}: {again} "
                           "writes it") from None
    click.echo(f"wrote {report_path}")


# A family's problem option -> the option of `escfit fit` that gives it (for refusals)
FIT_FLAGS = {"fmt": "--format", "notch_deg": "--notch-deg", "unit": "--unit", "solver": "--solver",
             "material": "--material", **{f"recording.{k}": f"--{k.replace('_', '-')}" for k in (
                 "time_column", "sample_rate", "angle_column", "angle_unit", "counts_per_turn", "scale")},
             "recording.start": "--start", "recording.stop": "--stop", "recording.release": "--release"}


def _column(text: str | None):
    """A column option: a 1-based position when it is a whole number, else a name."""
    return int(text) if text is not None and text.strip().isdigit() else text


def _run_fit_interruptible(run_fit, *args, **kwargs):
    """Run the fit; on Ctrl-C (or SIGTERM while sampling) say what was kept and how to go on (exit 130)."""
    try:
        return run_fit(*args, **kwargs)
    except KeyboardInterrupt:
        checkpoint = Path(f"{kwargs['out']}.emcee")
        if kwargs.get("method") == "emcee" and checkpoint.exists():
            import h5py

            try:
                with h5py.File(checkpoint, "r") as f:
                    done = int(f["chain"].shape[0])
            except (OSError, KeyError):
                done = 0
            click.echo(f"escfit: interrupted; {done} sampler steps are saved in {checkpoint}: run the same command "
                       "with --resume to continue (or --force to start again)", err=True)
        else:
            click.echo("escfit: interrupted; nothing was written", err=True)
        sys.exit(EXIT_INTERRUPTED)


def _print_summary(result) -> None:
    """The text table of a fit (see :func:`escfit.cli.summary.print_summary`)."""
    from .summary import print_summary

    print_summary(result)


@cli.command()
@click.argument("results", type=click.Path(dir_okay=False))
@click.option("--out", type=click.Path(dir_okay=False), default=None, help="Report file (default <results>.html).")
@click.option("--format", "fmt", type=click.Choice(["html", "md"]), default="html", show_default=True)
@click.option("--force", is_flag=True, help="Replace an existing report.")
@click.option("--title", default=None, help="Report title (default: the recipe's title kept with the fit, else the "
                                            "scene's, else the data file's name).")
def report(results, out, fmt, force, title):
    """Write a report (HTML with embedded figures, or Markdown) of a saved fit."""
    from ..report import make_report

    out = out or str(Path(results).with_suffix(".html" if fmt == "html" else ".md"))
    _check_outputs({"--out": out}, {"results": results},
                   companions={"--out": REPORT_FIGURE_NAMES} if fmt == "md" else None)
    click.echo(f"wrote {make_report(results, out, fmt=fmt, force=force, title=title)}")


def main() -> None:
    """Console-script entry point (the process ends as :func:`escfit.cli.exit.run_and_exit` says)."""
    from .exit import run_and_exit

    leave_out(unused_by(sys.argv[1:]))  # this process runs one command and ends with it
    quiet_third_party_warnings()
    run_and_exit(cli, prog_name="escfit")


if __name__ == "__main__":
    main()
