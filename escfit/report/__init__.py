"""Reports of saved fits: self-contained HTML (figures embedded) or Markdown (figures beside it).

Reports read the results file only; matplotlib, ArviZ's plotting and Jinja2 are imported when a
report is made.  The HTML page is rendered from ``templates/report.html.j2`` with autoescaping,
so text from the scene or the recording (titles, notes) is shown, never interpreted.

Sections: title, fit statistics, parameter table (display units: angles in deg, torques per
inertia in rad/s^2, see :mod:`escfit.core.display`), warnings, notes on the recording, figures
with captions, sampler diagnostics, provenance and the scene.
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
from .tables import fit_statistics, parameter_table, provenance_rows, sampler_rows

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


def _units_note(units: list[str]) -> str:
    """A line saying which display units differ from the file's (empty when none do)."""
    said = []
    if "deg" in units or "deg/s" in units:
        said.append("angles are shown in degrees")
    if "rad/s^2" in units:
        said.append("torques per inertia (R, X) in rad/s^2")
    if not said:
        return ""
    return "Display units: " + ", ".join(said) + "; the results file and its JSON and CSV summaries keep angles in radians."


def _md_text(text) -> str:
    """Text for Markdown outside code blocks: HTML special characters escaped (renderers pass raw
    HTML through), so a title or note with markup is shown, not interpreted; control characters
    are shown as escapes."""
    return html.escape(visible(text, keep="\n\t"), quote=False)


def _md_cell(text: str) -> str:
    return _md_text(text).replace("|", "\\|").replace("\n", " ")


def make_report(path: str | Path, out: str | Path, *, fmt: str = "html", force: bool = False,
                title: str | None = None) -> Path:
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
    res = load_fit(path)
    a = res.attrs
    page = {
        "title": report_title(res, title),
        "data_name": Path(a.get("data_file", "") or "").name,
        "fit_stats": fit_statistics(res),
        "warnings": [display_text(w, load_unit(json.loads(res.attrs.get("meanings", "{}") or "{}")))
                     for w in res.warnings],
        "notes": res.notes,
        "provenance": provenance_rows(res, path),
        "scene": a.get("scene", ""),
    }
    head, rows = parameter_table(res)
    page["units_note"] = _units_note([r[1] for r in rows])
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
            **page, head=head, rows=rows, note_col=note_col, figures=embed(figures), diagnostics=embed(diagnostics),
            sampler_text=sampler_text, sampler_head=sampler_head, sampler_rows=sampler_table)
    with atomic_path(out, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return out


def _markdown(page, head, rows, sampler_text, sampler_head, sampler_table, figures, diagnostics, images) -> str:
    lines = [f"# {_md_text(page['title'])}", "", _md_text(page["fit_stats"]), "", "## Parameters", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(_md_cell(c) for c in r) + " |" for r in rows]
    if page["units_note"]:
        lines += ["", page["units_note"]]
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
