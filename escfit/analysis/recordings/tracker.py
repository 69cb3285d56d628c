"""Tracker (physlets.org, Open Source Physics) video tracks: the ``.trk`` file and data-table exports.

A video tracker follows a point (a pendulum's bob, a marker on a wheel's rim) in the image plane,
so the file holds positions, not an angle.  The angle is found from the arc the point runs on:
a circle is fitted to the positions (an algebraic fit refined by geometric least squares), its
centre is the pivot, and the angle is ``atan2`` of the position about it, counter-clockwise
positive in the file's coordinates (Tracker's world frame has y up; the ``.trk`` pixel frame has
y down, so there a clockwise turn on screen is positive), zero at the mean direction of the
track.  A note gives the pivot, the radius and its standard error: an angle is an arc over that
radius, so a radius known to 5 % scales every amplitude (and so R) by up to 5 %.  A track whose
arc spans less than 4 deg (nearly straight) is refused: the pivot is then not determined.

``.trk`` (Tracker's XML, e.g. Tracker 6.3.1, ``Dämpfung.trk`` of HeiLaut/resonance_pendulum, MIT):
``<object class="...TrackerPanel">`` with a ``videoclip`` (``startframe``, ``stepsize``,
``starttime`` ms, the video's ``delta_t`` ms per frame) and ``tracks``: each
``...PointMass`` has a ``name`` and ``framedata``, an array whose item ``[k]`` (frame k) holds
``x`` and ``y`` in image pixels.  Time = (k - startframe) * delta_t + starttime.

Data-table export (File > Export > Data): optionally a first line naming the track
(``mass A``), then a header ``t x y`` (tab-, comma- or space-separated, the decimal mark of the
user's locale) and the rows, in the units of the track's calibration (m, or pixels).  When the
table has an angle column (``θ``, ``theta``, ``angle``) that one is read as it is.
"""

from __future__ import annotations

import hashlib
import math
import re
from pathlib import Path

import numpy as np

from ...core.errors import DataError
from ...core.tabletext import decode_lenient, numbered_lines
from .packed import XML_MAX_BYTES, parse_xml, read_capped
from .columns import Columns, series_from_columns
from .rawtable import scan_text, table_columns
from .recording_spec import RecordingSpec
from .series import TimeSeries

__all__ = ["read_trk", "read_tracker_table", "arc_angle", "sniff_tracker_table"]

MIN_ARC_DEG = 4.0


def arc_angle(x: np.ndarray, y: np.ndarray, where: str) -> tuple[np.ndarray, str]:
    """The angle (rad) of positions ``x, y`` about the centre of the circle they lie on, and a note.

    Raises
    ------
    DataError
        Fewer than 5 positions, or an arc too flat to locate its centre.
    """
    from scipy.optimize import least_squares

    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 5:
        raise DataError(f"only {int(ok.sum())} tracked positions: the arc's centre cannot be found", where)
    xs, ys = x[ok], y[ok]
    mx, my = xs.mean(), ys.mean()
    u, v = xs - mx, ys - my
    scale = math.hypot(u.std(), v.std()) or 1.0
    u, v = u / scale, v / scale
    a = np.column_stack([u, v, np.ones_like(u)])
    (d, e, f), *_ = np.linalg.lstsq(a, u**2 + v**2, rcond=None)
    c0 = np.array([d / 2, e / 2])
    r0 = math.sqrt(max(f + c0 @ c0, 1e-12))

    def resid(p):
        return np.hypot(u - p[0], v - p[1]) - p[2]

    fit = least_squares(resid, np.r_[c0, r0], method="lm")
    cx, cy, r = fit.x
    dof = max(1, u.size - 3)
    s2 = float(fit.fun @ fit.fun) / dof
    try:
        cov = np.linalg.inv(fit.jac.T @ fit.jac) * s2
        dr = math.sqrt(max(cov[2, 2], 0.0))
    except np.linalg.LinAlgError:
        dr = math.inf
    phi = np.unwrap(np.arctan2(v - cy, u - cx))
    span = math.degrees(np.ptp(phi))
    if span < MIN_ARC_DEG or not math.isfinite(r) or not dr < 0.5 * abs(r):
        raise DataError(f"the track spans {span:.2g} deg of arc: too flat to locate the pivot; track a point farther "
                        "from the axis, or export the angle (θ) and read that column", where)
    zero = math.atan2(np.sin(phi).mean(), np.cos(phi).mean())
    theta = np.full(x.size, np.nan)
    theta[ok] = phi - zero - 2 * math.pi * round((phi.mean() - zero) / (2 * math.pi))
    px, py, pr, pdr = mx + scale * cx, my + scale * cy, scale * r, scale * dr
    note = (f"angle about the centre of the tracked arc: pivot at ({px:.5g}, {py:.5g}), radius {pr:.5g} +- {pdr:.2g} "
            f"({100 * pdr / pr:.2g} %), arc {span:.3g} deg; zero at the track's mean direction")
    return theta, note


def _props(obj) -> dict:
    return {p.get("name"): p for p in obj.findall("property")}


def _value(prop, default=None):
    if prop is None:
        return default
    try:
        return float(prop.text)
    except (TypeError, ValueError):
        return default


def read_trk(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a Tracker ``.trk`` file: a point mass's pixel track, turned into an angle (see the
    module docstring); ``[recording] angle_column`` names the track when there are several."""
    spec = spec or RecordingSpec()
    where = str(path)
    raw = read_capped(path, XML_MAX_BYTES, "a Tracker file")
    root = parse_xml(raw, where)
    if "tracker" not in (root.get("class") or "").lower():
        raise DataError(f"XML object {root.get('class')!r}, not a Tracker panel: not a .trk file", where)
    top = _props(root)
    clip = top.get("videoclip")
    clip_obj = clip.find("object") if clip is not None else None
    cp = _props(clip_obj) if clip_obj is not None else {}
    video = cp.get("video")
    vp = _props(video.find("object")) if video is not None and video.find("object") is not None else {}
    dt = _value(vp.get("delta_t")) or _value(_props(top["clipcontrol"].find("object")).get("delta_t")
                                              if "clipcontrol" in top else None)
    if not dt or not dt > 0:
        raise DataError("the video clip gives no frame interval (delta_t): no clock for the track", where)
    start = _value(cp.get("startframe"), 0.0)
    t0 = _value(cp.get("starttime"), 0.0) or 0.0
    tracks = {}
    for obj in root.iter("object"):
        if not (obj.get("class") or "").endswith("PointMass"):
            continue
        props = _props(obj)
        name = (props["name"].text if "name" in props else f"track {len(tracks) + 1}") or ""
        frames = {}
        data = props.get("framedata")
        for item in (data.findall("property") if data is not None else []):
            fd = item.find("object")
            if fd is None:
                continue
            fp = _props(fd)
            k = int(item.get("name", "[-1]").strip("[]"))
            x, y = _value(fp.get("x")), _value(fp.get("y"))
            if x is not None and y is not None:
                frames[k] = (x, y)
        if frames:
            tracks[name] = frames
    if not tracks:
        raise DataError("no point-mass track with positions in the file", where)
    if isinstance(spec.angle_column, str):
        if spec.angle_column not in tracks:
            raise DataError(f"[recording] angle_column = {spec.angle_column!r}: no such track; tracks: {list(tracks)}",
                            where)
        name = spec.angle_column
    elif len(tracks) == 1:
        name = next(iter(tracks))
    else:
        raise DataError(f"{len(tracks)} tracks ({', '.join(tracks)}); set [recording] angle_column to the track's name",
                        where)
    k = np.array(sorted(tracks[name]))
    xy = np.array([tracks[name][i] for i in k])
    theta, note = arc_angle(xy[:, 0], -xy[:, 1], where)  # pixel y runs down: flip to a right-handed frame
    time = ((k - start) * dt + t0) / 1000.0
    version = top["semantic_version"].text if "semantic_version" in top else "?"
    cols = Columns(where, ["t", "angle"], [], [], units=["s", "rad"], values={0: time, 1: theta},
                   describe=f"Tracker {version} .trk, track {name!r} ({k.size} frames, {dt:g} ms per frame)",
                   notes=[note + " (image y flipped to point up)"])
    spec = RecordingSpec(**{**spec.__dict__, "angle_column": None, "time_column": None, "angle_unit": None})
    return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())


def sniff_tracker_table(text: str) -> bool:
    """Whether text starts like a Tracker data export: a track name, then ``t x y`` names."""
    lines = [s for _, s in numbered_lines(text[:2000]) if s.strip()][:3]
    for head in lines[:2]:
        names = [n.lower() for n in head.replace(",", " ").replace(";", " ").split()]
        if len(names) >= 3 and names[0] == "t" and "x" in names and "y" in names:
            return True
    return False


def _tracked_rows(body: list, where: str, notes: list) -> list:
    """The header and rows of an export without Tracker's trailing tabs and its untracked frames.

    Tracker ends each line with its delimiter (``t<TAB>x<TAB>y<TAB>``) in some exports, and
    writes a frame where the track has no position as its time followed by empty cells
    (``4.369<TAB><TAB>``).  The trailing delimiter is dropped from every line, and a row that then
    holds its time alone is left out with a note.
    """
    out = [(n, line.rstrip(" \t,;")) for n, line in body]
    if not out:
        return out
    split = lambda line: re.split(r"\t|,|;|\s+", line.strip())  # noqa: E731
    width = len(split(out[0][1]))
    rows = [(n, line) for n, line in out[1:] if not (width >= 2 and len(split(line)) == 1)]
    dropped = len(out) - 1 - len(rows)
    if dropped:
        notes.append(f"{dropped} frame(s) without a position (the track was not marked there) left out")
    return [out[0]] + rows


def _constant(values: np.ndarray) -> bool:
    finite = values[np.isfinite(values)]
    return bool(finite.size == 0 or np.ptp(finite) == 0)


def read_tracker_table(path: str | Path, spec: RecordingSpec | None = None) -> TimeSeries:
    """Read a Tracker data-table export (see the module docstring)."""
    spec = spec or RecordingSpec()
    where = str(path)
    raw = Path(path).read_bytes()
    notes: list[str] = []
    _, _, body = scan_text(decode_lenient(raw, where, notes), where)
    track = None
    first, second = body[0][1].strip(), body[1][1].strip().lower() if len(body) > 1 else ""
    if len(body) > 2 and re.match(r"t[\s,;]", second) and not re.match(r"t[\s,;]", first.lower()):
        track, body = first.split("\t")[0].strip(), body[1:]
    body = _tracked_rows(body, where, notes)
    cols = table_columns(body, where, notes)
    if cols.names is None:
        raise DataError("no header (t x y) above the track's rows", where)
    low = [n.lower().split("(")[0].strip() for n in cols.names]
    cols.describe = f"Tracker data export{f' of track {track!r}' if track else ''} ({cols.describe})"
    if track:
        cols.meta["track"] = track
    angle = [i for i, n in enumerate(low) if n in ("θ", "theta", "angle", "θ_v")]
    from .columns import _floats

    if spec.angle_column is not None or (angle and not ({"x", "y"} <= set(low) and _constant(_floats(cols, angle[0])))):
        return series_from_columns(cols, spec, sha256=hashlib.sha256(raw).hexdigest())
    it = next((i for i, n in enumerate(low) if n in ("t", "time")), None)
    if "x" not in low or "y" not in low or it is None:
        raise DataError(f"the header {cols.names} has no t, x, y columns (nor an angle θ)", f"{where}:{cols.header_line}")
    if angle:
        notes.append(f"column {cols.names[angle[0]]!r} holds one value in every row: the angle is taken from x and y")
    ix, iy = low.index("x"), low.index("y")
    x, y, t = _floats(cols, ix), _floats(cols, iy), _floats(cols, it)
    theta, note = arc_angle(x, y, where)
    tu = cols.unit(it)
    out = Columns(where, ["t", "angle"], [], cols.lines, units=[tu or "s", "rad"], values={0: t, 1: theta},
                  header_line=cols.header_line, describe=cols.describe, notes=notes + [note], meta=cols.meta)
    return series_from_columns(out, spec, sha256=hashlib.sha256(raw).hexdigest())
