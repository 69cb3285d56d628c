"""Reports of saved fits: self-contained HTML (figures embedded) or Markdown (figures beside it).

Reports read the results file only; matplotlib and Jinja2 are imported when a report is made
(ArviZ is not: the corner plot is drawn with matplotlib, :mod:`escfit.report.corner`).  The HTML page is rendered from ``templates/report.html.j2`` with autoescaping,
so text from the scene or the recording (titles, notes) is shown, never interpreted.

Sections: title, the answer in plain sentences (:mod:`escfit.report.plain`), fit statistics, parameter table (plain names and symbols, held parameters
listed, display units: angles in deg, torques per inertia in rad/s^2, see
:mod:`escfit.core.display` and :mod:`escfit.core.names`), derived quantities (Q, decrement,
losses per swing, torques in N m, :mod:`escfit.report.quantities`), warnings, notes on the
recording, figures with captions, sampler diagnostics, provenance and the scene.
"""

from __future__ import annotations

import base64
import html
import json
import re
import tomllib
from pathlib import Path

from ..core.atomic import atomic_path, check_output_folder, refuse_clobbering_inputs, refuse_existing
from ..core.display import display_text, load_unit
from ..core.errors import MissingDependency
from ..results import FitResult, load_fit
from .plain import plain_summary
from .quantities import derived_rows
from .params import held_table
from .tables import failures_text, fit_statistics, parameter_table, provenance_rows, sampler_rows

__all__ = ["make_report", "parameter_table", "report_title"]

_TEMPLATES = Path(__file__).with_name("templates")


def visible(text: str, keep: str = "") -> str:
    """``text`` with control characters (escape sequences, NUL, ...) shown as ``\\xNN`` escapes
    instead of being passed to a terminal, a Markdown renderer or a browser; ``keep`` lists
    those left as they are (a paragraph's line ends)."""
    return "".join(c if c.isprintable() or c in keep or c == " " else
                   (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}") for c in str(text))


def report_title(res: FitResult, title: str | None = None) -> str:
    """The report's title: ``title`` if given, else the fit's ``title`` attribute (a recipe's),
    else the scene's own ``title``, else the data file's name; one line of visible characters."""
    for candidate in (title, res.attrs.get("title")):
        if candidate:
            return visible(candidate)
    try:
        scene_title = tomllib.loads(res.attrs.get("scene", "") or "").get("title")
    except tomllib.TOMLDecodeError:
        scene_title = None
    if scene_title:
        return visible(scene_title)
    return visible(Path(res.attrs.get("data_file", "") or "fit").name or "escfit fit")


def _environment():
    try:
        import jinja2
    except ImportError:
        raise MissingDependency("HTML reports need jinja2: pip install 'escfit[plot]'") from None
    return jinja2.Environment(loader=jinja2.FileSystemLoader(_TEMPLATES), autoescape=True,
                              trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True)


def _units_note(units: list[str], res=None) -> str:
    """A line saying which display units differ from the file's, and the sign of the centre (empty when
    nothing needs saying)."""
    said = []
    if "deg" in units or "deg/s" in units:
        said.append("angles are shown in degrees")
    if "rad/s^2" in units:
        said.append("torques per inertia (R, X) in rad/s^2")
    if {"gf", "in", "1/gf", "s/ft"} & set(units):
        said.append("forces in gram-force (1 gf = 9.807 mN), lengths in inches and speeds in ft/s, as the rig's "
                    "readings")
    if "lbf in" in units:
        said.append("torques in lbf in, as the source's")
    text = ("Display units: " + ", ".join(said) + "; the results file and its JSON and CSV summaries keep SI units "
            "(angles in radians).") if said else ""
    names = res.parameter_names if res is not None else []
    obs = res.arrays("observed_data") if res is not None else None
    rate = obs is not None and obs["reading"].attrs.get("units") == "rad/s"
    if rate and ("observation.offset" in names or "observation.offset_rate" in names):
        text += (" The rate's zero (the sensor's bias) is what the sensor reads when the oscillator is still, and its "
                 "drift how fast that moves; the files store the zero offset, observation.offset, which is minus it.")
    elif "observation.offset" in names or "observation.offset_rate" in names:
        text += (" The centre of the swing is where the sensor reads when the oscillator is at its centre, and its "
                 "drift is how fast that moves, positive towards larger readings, as in the notes; the files store "
                 "the scale's zero offset, observation.offset, which is minus the centre.")
    return text.strip()


def _md_text(text) -> str:
    """Text for Markdown outside code blocks: HTML special characters escaped (renderers pass raw
    HTML through), so a title or note with markup is shown, not interpreted; control characters
    are shown as escapes."""
    return html.escape(visible(text, keep="\n\t"), quote=False)


def _md_cell(text: str) -> str:
    return _md_text(text).replace("|", "\\|").replace("\n", " ")


def make_report(path: str | Path, out: str | Path, *, fmt: str = "html", force: bool = False,
                title: str | None = None, result: FitResult | None = None) -> Path:
    """Write a report of the fit stored at ``path``.

    Parameters
    ----------
    path
        The results file (HDF5) written by :func:`escfit.fit`.
    out
        The report file.  Markdown figures go beside it as ``<stem>_<figure>.png``.
    fmt
        ``"html"`` (self-contained, images embedded as base64 PNG) or ``"md"``.
    force
        Replace existing files.  Without it, a report whose file or any of whose figure files
        exists is refused before anything is written.
    title
        The report's title; by default the fit's (a recipe's ``title``), else the scene's,
        else the data file's name (see :func:`report_title`).
    result
        The fit just written to ``path`` by this process (:func:`escfit.fit`'s return): the
        report is made from it instead of reading the file back (the same page, without the
        read).

    Returns
    -------
    pathlib.Path
        ``out``.

    Raises
    ------
    ResultsError
        The results file cannot be read, or an output file exists and ``force`` is false.
    """
    from .plots import report_figures

    if fmt not in ("html", "md"):
        raise ValueError(f"report format must be 'html' or 'md', got {fmt!r}")
    out = Path(out)
    refuse_clobbering_inputs({"the report": out}, {"results": path})
    check_output_folder(out, "the report", companions=48 if fmt == "md" else 0)  # md: <stem>_<figure>.png
    refuse_existing(out, force)
    res = load_fit(path) if result is None else result
    a = res.attrs
    page = {
        "title": report_title(res, title),
        "data_name": Path(a.get("data_file", "") or "").name,
        "fit_stats": fit_statistics(res),
        "failures": failures_text(res),
        "warnings": [display_text(w, load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}")))
                     for w in res.warnings],
        "notes": res.notes,
        "provenance": provenance_rows(res, path),
        "scene": a.get("scene", ""),
        "plain": plain_summary(res),
    }
    head, rows = parameter_table(res, plain=True)
    page["units_note"] = _units_note([r[1] for r in rows], res)
    page["derived_head"], page["derived_rows"], page["derived_note"] = derived_rows(res)
    page["held_head"], page["held_rows"] = held_table(res)
    sampler_text, sampler_head, sampler_table = sampler_rows(res)
    figures, diagnostics = report_figures(res)
    if fmt == "md":
        images = {t: out.with_name(f"{out.stem}_{t.replace(' ', '_')}.png") for t in [*figures, *diagnostics]}
        for image_path in images.values():  # refuse before anything is written
            refuse_existing(image_path, force)
        text = _markdown(page, head, rows, sampler_text, sampler_head, sampler_table, figures, diagnostics, images)
        for t, image in {**figures, **diagnostics}.items():
            with atomic_path(images[t], force=force) as tmp:
                tmp.write_bytes(bytes(image))
    else:
        def embed(items):
            return [{"title": t, "caption": getattr(img, "caption", ""), "b64": base64.b64encode(img).decode()}
                    for t, img in items.items()]

        note_col = head.index("note") if "note" in head else -1
        text = _environment().get_template("report.html.j2").render(
            **page, head=head, rows=rows, note_col=note_col, code_col=len(head) - 1, figures=embed(figures), diagnostics=embed(diagnostics),
            sampler_text=sampler_text, sampler_head=sampler_head, sampler_rows=sampler_table)
    with atomic_path(out, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out


def _markdown(page, head, rows, sampler_text, sampler_head, sampler_table, figures, diagnostics, images) -> str:
    lines = [f"# {_md_text(page['title'])}", ""]
    if page["plain"]:
        lines += ["## In plain words", "", *[f"{_md_text(p)}\n" for p in page["plain"]]]
    lines += [_md_text(page["fit_stats"])]
    if page["failures"]:
        lines += ["", _md_text(page["failures"])]
    lines += ["", "## Parameters", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(_md_cell(c) for c in r) + " |" for r in rows]
    if page["units_note"]:
        lines += ["", page["units_note"]]
    if page["held_rows"]:
        hh = page["held_head"]
        lines += ["", f"Held at the scene's values (not fitted): {len(page['held_rows'])}", "",
                  "| " + " | ".join(hh) + " |", "|" + "---|" * len(hh)]
        lines += ["| " + " | ".join(_md_cell(c) for c in r) + " |" for r in page["held_rows"]]
    if page["derived_rows"]:
        dh = page["derived_head"]
        lines += ["", "## Derived quantities", "", "| " + " | ".join(dh) + " |", "|" + "---|" * len(dh)]
        lines += ["| " + " | ".join(_md_cell(c) for c in r) + " |" for r in page["derived_rows"]]
        lines += ["", _md_text(page["derived_note"])]
    lines += ["", "## Warnings: identifiability, convergence and misfit", ""]
    lines += [f"- {_md_text(w)}" for w in page["warnings"]] or ["- no warnings"]
    if page["notes"]:
        lines += ["", "## Notes on the recording", ""] + [f"- {n}" for n in page["notes"]]
    lines += ["", "## Figures"]
    for t, image in figures.items():
        lines += ["", f"### {t.capitalize()}", "", f"![{t}]({images[t].name})", "", f"*{image.caption}*"]
    if sampler_text:
        lines += ["", "## Sampler diagnostics", "", sampler_text]
        if sampler_head:
            lines += ["", "| " + " | ".join(sampler_head) + " |", "|" + "---|" * len(sampler_head)]
            lines += ["| " + " | ".join(_md_cell(c) for c in r) + " |" for r in sampler_table]
        for t, image in diagnostics.items():
            lines += ["", f"![{t}]({images[t].name})", "", f"*{image.caption}*"]
    lines += ["", "## Provenance", ""] + [f"- {k}: `{v}`" for k, v in page["provenance"]]
    runs = [len(r) for r in re.findall(r"`+", page["scene"])]
    fence = "`" * max(3, max(runs, default=0) + 1)  # longer than any run in the scene: it cannot close the block
    lines += ["", "## Scene", "", fence + "toml", page["scene"], fence]
    return "\n".join(lines) + "\n"
