"""Collect every scene key escfit reads, by watching its scene readers read.

Run as a script (``python docs/_ext/scenekeys_collect.py ROOT``) it prints a JSON catalogue;
the Sphinx extension ``escfit_scenekeys`` renders it as the scene-key reference.  Nothing
here is hand-listed: the catalogue is what the code does.

How
---
Every scene reader checks a table's keys with :func:`escfit.core.scene.check_keys` and turns a
number into a named parameter with :func:`escfit.core.params.read_param` (which carries the
parameter's name, unit kind, physical range and one-line meaning).  Both are wrapped before any
other escfit module is imported, so every reader binds the wrappers, and then

1. every shipped scene (``datasets/``, ``fits/``) is read, and every shipped fit recipe's
   problem is built (which reads ``[observation]``, ``[fit]`` and ``[recording]``), and every
   scene beside a recording in the same folder is tried on it;
2. every key a reader allowed but no shipped file used is *probed*: the key is set to a test
   value in a document that reached its table, alone and beside the table's other keys, and
   the document read again; a probe that fails still records what the reader declared before
   it refused the value;
3. every balance effect of the registry (``escfit.balance.effects.EFFECTS``) that no shipped
   scene names is probed the same way from an empty table;
4. the observation models of the balance family (classes with ``kind`` and ``KEYS``), the
   ``[recording]`` options (:class:`~escfit.analysis.recordings.recording_spec.RecordingSpec`,
   with its numpydoc attributes) and the keys of a parameter table are read from the code.

A new key, effect or observation model therefore appears in the reference without editing the
documentation.  This script runs in its own process: the wrappers must be in place before
escfit's modules are imported, and they should not stay in the process that builds the site.
"""

from __future__ import annotations

import contextlib
import copy
import glob
import importlib
import io
import json
import math
import pkgutil
import re
import sys
import time
import tomllib
import warnings
from pathlib import Path

PROBE = 0.5  # a value every numeric reader can at least look at
DATA_SUFFIXES = {".csv", ".json", ".txt", ".mat", ".dat", ".tsv"}
_BRACKET = re.compile(r"\[([^\[\]]+(?:\[\d+\])?[^\[\]]*)\](.*)$")


def _num(x):
    """JSON has no infinity: +-inf as strings."""
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return x


class Catalogue:
    """What the readers were seen to declare, by (family, table, variant)."""

    def __init__(self):
        self.tables: dict[tuple, dict] = {}
        self.params: list[dict] = []
        self.values: list[dict] = []
        self.final: dict[tuple, str] = {}
        self.family = None  # model of the document being read
        self.context = None  # (doc, data, options) of the document being read
        self.where = None  # the name given to the document being read

    # --- recording -----------------------------------------------------------------------
    def table(self, family, path, variant, allowed=(), required=(), array=False, source=""):
        key = (family, path, variant)
        entry = self.tables.setdefault(key, {"family": family, "path": path, "variant": variant, "allowed": set(),
                                             "required": set(), "array": array, "source": source,
                                             "contexts": []})
        entry["allowed"] |= set(allowed)
        entry["required"] |= set(required)
        entry["array"] = entry["array"] or array
        entry["source"] = entry["source"] or source
        if self.context is not None:
            entry["contexts"] = sorted([*entry["contexts"], self.context], key=lambda c: c[3])[:3]
        return entry


def _split_where(where: str, scene_where: str | None):
    """``"file [effects.escapement 2].X"`` -> (``"effects.escapement"``, ``"X"``, array)."""
    if scene_where and where.startswith(scene_where):
        rest = where[len(scene_where):].strip()
    else:
        rest = where.split(" ", 1)[1].strip() if " " in where else ""
    if rest.startswith("(recipe)"):
        return "(recipe)", rest[len("(recipe)"):].lstrip("."), False
    m = _BRACKET.search(rest)
    if not m:
        return "", rest.lstrip(".") or None, False
    inside, suffix = m.group(1), m.group(2)
    array = bool(re.search(r" \d+$", inside))
    inside = re.sub(r" \d+$", "", inside)
    key = re.sub(r"\[\d+\]", "", suffix.lstrip(".")) or None
    return inside, key, array


def _variant(frame_depth: int = 2):
    """The observation model being read: the ``kind`` of a ``cls`` (or a ``model``) up the stack."""
    f = sys._getframe(frame_depth)
    for _ in range(8):
        if f is None:
            break
        cls = f.f_locals.get("cls")
        if isinstance(cls, type) and isinstance(getattr(cls, "kind", None), str) and hasattr(cls, "KEYS"):
            return cls.kind
        f = f.f_back
    return None


def install(cat: Catalogue):
    """Wrap check_keys and read_param before any reader module is imported."""
    for name in list(sys.modules):
        if name.startswith("escfit.") and name not in ("escfit.core", "escfit.core.errors", "escfit.core.version",
                                                       "escfit.core.units", "escfit.core.params", "escfit.core.scene"):
            raise RuntimeError(f"{name} was imported before the readers were wrapped")
    import escfit.core.params as cp
    import escfit.core.scene as cs
    import escfit.core.units as cu

    orig_check, orig_read, orig_canonical = cs.check_keys, cp.read_param, cu.to_canonical

    def check_keys(table, allowed, where, required=frozenset()):
        path, _key, array = _split_where(str(where), cat.where)
        variant = _variant() if path == "observation" and cat.family == "balance" else None
        caller = sys._getframe(1).f_code
        source = f"{caller.co_filename.split('escfit/')[-1]}:{caller.co_name}"
        cat.table(cat.family, path, variant, allowed, required, array, source)
        return orig_check(table, allowed, where, required)

    def read_param(raw, **kw):
        path, key, _array = _split_where(str(kw.get("where", "")), cat.where)
        from escfit.core.units import CANONICAL

        kind = kw.get("kind", "dimensionless")
        cat.params.append({
            "family": cat.family, "path": path, "key": key,
            "variant": _variant() if path == "observation" and cat.family == "balance" else None,
            "name": re.sub(r"\[\d+\]", "[i]", kw.get("name", "")), "kind": kind,
            "input_unit": CANONICAL.get(kind, ""), "unit": kw.get("unit") or CANONICAL.get(kind, ""),
            "lower": _num(float(kw.get("lower", -math.inf))), "upper": _num(float(kw.get("upper", math.inf))),
            "lower_open": bool(kw.get("lower_open", False)),
            "meaning": re.sub(r"window \d+", "window i", kw.get("meaning", "")),
            "bare_limit": _num(kw.get("bare_limit")), "converted": kw.get("convert") is not None,
        })
        return orig_read(raw, **kw)

    def to_canonical(value, kind, where="", *args, **kw):
        # numbers that are not parameters (window limits, banking angle, notch angle, lever ...)
        path, key, _array = _split_where(str(where), cat.where)
        if cat.family is not None:  # a key inside the brackets ([rig.k]) is split off at the end
            cat.values.append({"family": cat.family, "path": path, "key": key, "kind": kind,
                               "variant": _variant() if path == "observation" and cat.family == "balance" else None,
                               "unit": cu.CANONICAL.get(kind, "")})
        return orig_canonical(value, kind, where, *args, **kw)

    cs.check_keys, cp.read_param, cu.to_canonical = check_keys, read_param, to_canonical


# --- reading the shipped files ---------------------------------------------------------------

def _quiet(fn, *args, **kwargs):
    """Call ``fn``; any exception or output is swallowed (a probe is expected to fail often)."""
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
            contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        try:
            return fn(*args, **kwargs)
        except Exception:
            return None


def _read(cat: Catalogue, doc: dict, where: str, data: str | None = None, options: dict | None = None):
    """Parse a scene document (and build its fit problem when a recording is given)."""
    from escfit.core.family import family_names, get_family

    model = doc.get("model")
    if model not in family_names():
        return None
    # files read quickest first: a probe then reuses the cheapest document that reached a table
    cost = 0 if data is None else Path(data).stat().st_size if Path(data).exists() else 0
    cat.family, cat.where, cat.context = model, where, (copy.deepcopy(doc), data, dict(options or {}), cost)
    try:
        scene = _quiet(get_family(model).parse, copy.deepcopy(doc), where=where, text="")
        for p in getattr(getattr(scene, "params", None), "params", {}).values():
            # the unit a parameter ends in (a reader may set it after read_param, as for 1/N)
            cat.final.setdefault((model, re.sub(r"\[\d+\]", "[i]", p.name)), p.unit)
        if scene is not None and data is not None:
            from escfit.inference import make_problem

            _quiet(make_problem, scene, data, **(options or {}))
        return scene
    finally:
        cat.family = cat.where = cat.context = None


def _recipe_options(model: str, recipe: dict) -> dict:
    """A recipe's problem options, as ``escfit fit`` passes them."""
    names = {"balance": {"format": "fmt", "notch_deg": "notch_deg", "unit": "unit", "solver": "solver"},
             "friction_rig": {"material": "material"}, "geneva": {"format": "fmt"}}.get(model, {})
    return {opt: recipe[key] for key, opt in names.items() if key in recipe}


def read_shipped(cat: Catalogue, root: Path) -> dict:
    counts = {"scenes": 0, "recipes": 0, "pairs": 0}
    root = root.resolve()
    tomls = sorted({*glob.glob(str(root / "datasets/**/*.toml"), recursive=True),
                    *glob.glob(str(root / "fits/**/*.toml"), recursive=True)})
    scenes: dict[Path, dict] = {}
    per_folder: dict[Path, int] = {}
    for p in map(Path, tomls):
        per_folder[p.parent] = per_folder.get(p.parent, 0) + 1
        if per_folder[p.parent] > 3 and "fits" not in p.relative_to(root.resolve()).parts:
            continue  # a generated fleet: twenty scenes with one scene's tables
        try:
            doc = tomllib.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            continue
        if "model" in doc:
            scenes[p.resolve()] = doc
            if _read(cat, doc, p.name) is not None:
                counts["scenes"] += 1
        elif "scene" in doc and "data" in doc:
            _read_recipe_keys(cat, p)
            scene_path = (p.parent / str(doc["scene"])).resolve()
            try:
                sdoc = tomllib.loads(scene_path.read_text(encoding="utf-8"))
            except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
                continue
            _read(cat, sdoc, scene_path.name, str((p.parent / str(doc["data"])).resolve()),
                  _recipe_options(sdoc.get("model", ""), doc))
            counts["recipes"] += 1
    # a scene beside recordings (datasets/recordings/: pulses_scene.toml next to monday_pulses.csv)
    folders: dict[Path, list[Path]] = {}
    for p in scenes:
        folders.setdefault(p.parent, []).append(p)
    for folder, paths in folders.items():
        data = sorted(f for f in folder.iterdir() if f.suffix in DATA_SUFFIXES and f.stat().st_size < 5_000_000)
        if len(data) > 12:
            continue
        for p in paths:
            if scenes[p].get("model") != "balance":
                continue
            for d in data:
                _read(cat, scenes[p], p.name, str(d))
                counts["pairs"] += 1
    return counts


def _read_recipe_keys(cat: Catalogue, path: Path) -> None:
    """Recipe keys, through the command line's own recipe reader when it has one."""
    try:
        main = importlib.import_module("escfit.cli.main")
    except Exception:
        return
    reader = getattr(main, "_read_recipe", None)
    if reader is not None:
        cat.family, cat.where = "(recipe)", str(path)
        try:
            _quiet(reader, path)
        finally:
            cat.family = cat.where = None


# --- probing keys no shipped file uses ------------------------------------------------------

def _at(doc: dict, path: str, create: bool = False):
    """The table at dotted ``path`` of ``doc`` (the first of an array of tables)."""
    node = doc
    for part in [p for p in path.split(".") if p]:
        if isinstance(node, list):
            node = node[0] if node else {}
        if part not in node:
            if not create:
                return None
            node[part] = {}
        node = node[part]
    if isinstance(node, list):
        node = node[0] if node else None
    return node if isinstance(node, dict) else None


def _seen_keys(cat: Catalogue) -> set:
    """Keys whose unit is known: parameters, and numbers read with a unit."""
    return {(p["family"], p["path"], p["variant"], p["key"]) for p in [*cat.params, *cat.values]}


def probe_tables(cat: Catalogue) -> int:
    """Tables a family allows that no shipped file has: read once as an empty table."""
    n = 0
    for entry in list(cat.tables.values()):
        if entry["path"] != "" or entry["family"] in (None, "(recipe)"):
            continue
        for key in sorted(entry["allowed"]):
            if any(t["family"] == entry["family"] and t["path"] == key for t in cat.tables.values()):
                continue
            for doc, data, options, _cost in entry["contexts"]:
                if key in doc:
                    break
                trial = copy.deepcopy(doc)
                trial[key] = {}
                _read(cat, trial, "probe.toml", data, options)
                n += 1
                if any(t["family"] == entry["family"] and t["path"] == key for t in cat.tables.values()):
                    break
    return n


def probe(cat: Catalogue, deadline: float) -> int:
    """Probe the keys no shipped file gives; a negative count says the time limit cut it short."""
    n = 0
    for entry in list(cat.tables.values()):
        if entry["family"] in (None, "(recipe)") or not entry["contexts"] or entry["path"] == "":
            continue
        seen = _seen_keys(cat)
        for key in sorted(entry["allowed"]):
            if (entry["family"], entry["path"], entry["variant"], key) in seen:
                continue
            if time.monotonic() > deadline:
                return -n
            if any(key in (_at(c[0], entry["path"]) or {}) for c in entry["contexts"]):
                continue  # a shipped file gave it and the reader read it: nothing more to see
            for doc, data, options, _cost in entry["contexts"]:
                if (entry["family"], entry["path"], entry["variant"], key) in _seen_keys(cat):
                    break
                for alone in (False, True):
                    trial = copy.deepcopy(doc)
                    table = _at(trial, entry["path"], create=True)
                    if table is None:
                        continue
                    if alone:
                        for other in list(table):
                            if other != key and other not in entry["required"] and other != "model":
                                del table[other]
                    table[key] = PROBE
                    _read(cat, trial, "probe.toml", data, options)
                    n += 1
    return n


def probe_effects(cat: Catalogue) -> int:
    """Every balance effect of the registry, read directly from probe tables.

    Each effect reads its own table (``Effect.read(table, ctx)``, here with an inertia of
    1 kg m^2 so physical torques convert), so an empty table shows the keys it allows (it
    refuses the table after checking them), and a table with a key set to :data:`PROBE`,
    alone or beside one other key (a static torque may need a kinetic one), shows the
    parameter that key declares.
    """
    from escfit.balance.effects import EFFECTS
    from escfit.balance.effects.base import ReadContext

    n = 0
    cat.family, cat.where = "balance", "probe.toml"
    try:
        for name, cls in EFFECTS.items():
            ctx = ReadContext(where="probe.toml", inertia=1.0, switching="angle")
            if ("balance", f"effects.{name}", None) not in cat.tables:
                _quiet(cls.read, {}, ctx)
                n += 1
            entry = cat.tables.get(("balance", f"effects.{name}", None))
            allowed = sorted(entry["allowed"]) if entry else []
            for key in allowed:
                for other in [None, *[o for o in allowed if o != key]]:
                    if ("balance", f"effects.{name}", None, key) in _seen_keys(cat):
                        break
                    _quiet(cls.read, {key: PROBE} if other is None else {other: PROBE / 2, key: PROBE}, ctx)
                    n += 1
    finally:
        cat.family = cat.where = None
    return n


# --- what the code declares without a reader call ---------------------------------------------

def declared(cat: Catalogue) -> dict:
    out: dict = {}
    import escfit.balance.observation as obs_pkg

    for m in pkgutil.iter_modules(obs_pkg.__path__, obs_pkg.__name__ + "."):
        mod = _quiet(importlib.import_module, m.name)
        for obj in vars(mod).values() if mod else ():
            if isinstance(obj, type) and obj.__module__ == mod.__name__ and isinstance(getattr(obj, "kind", None), str) \
                    and isinstance(getattr(obj, "KEYS", None), (set, frozenset)):
                cat.table("balance", "observation", obj.kind, obj.KEYS, (), False,
                          f"{mod.__name__.replace('escfit.', '').replace('.', '/')}.py:{obj.__name__}")
    from escfit.balance.effects import EFFECTS

    out["effects"] = {name: (cls.__doc__ or "").strip().splitlines()[0] for name, cls in EFFECTS.items()}
    spec_mod = _quiet(importlib.import_module, "escfit.analysis.recordings.recording_spec")
    if spec_mod is not None and hasattr(spec_mod, "RecordingSpec"):
        keys = list(getattr(spec_mod, "KEYS", ()))
        out["recording"] = {"keys": keys, "doc": _attributes(spec_mod.RecordingSpec.__doc__ or "")}
        cat.table("balance", "recording", None, keys, (), False, "analysis/recordings/recording_spec.py:RecordingSpec")
    import escfit.core.params as cp

    out["param_table_keys"] = sorted(getattr(cp, "_TABLE_KEYS", ()))
    from escfit.core.family import family_names

    out["models"] = family_names()
    return out


def _attributes(doc: str) -> dict:
    """``name : type`` / description pairs of a numpydoc ``Attributes`` section (names may be ``a, b``)."""
    lines = [line.rstrip() for line in doc.splitlines()]
    out, current, text = {}, None, []
    inside = False
    for i, line in enumerate(lines):
        s = line.strip()
        if s == "Attributes" and i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"}:
            inside = True
            continue
        if not inside or set(s) == {"-"}:
            continue
        if s and i + 1 < len(lines) and set(lines[i + 1].strip() or "x") == {"-"}:
            break  # the next section
        indent = len(line) - len(line.lstrip())
        if s and indent <= 4 and not line.startswith(" " * 8):
            if current:
                for name in current:
                    out[name] = " ".join(text)
            current = [n.strip() for n in s.split(":")[0].split(",")]
            text = []
        elif s and current:
            text.append(s)
    if current:
        for name in current:
            out[name] = " ".join(text)
    return out


def collect(root: Path, budget_s: float = 600.0) -> dict:
    start = time.monotonic()
    cat = Catalogue()
    sys.path.insert(0, str(root))
    install(cat)
    counts = read_shipped(cat, root)
    extra = declared(cat)
    counts["effect_probes"] = probe_effects(cat)
    counts["table_probes"] = probe_tables(cat)
    counts["key_probes"] = probe(cat, start + budget_s)
    counts["seconds"] = round(time.monotonic() - start, 1)
    tables = []
    for e in cat.tables.values():
        if e["family"] is None:
            continue
        tables.append({k: (sorted(v) if isinstance(v, set) else v) for k, v in e.items() if k != "contexts"})
    known = {(t["family"], t["path"]) for t in tables}
    for rec in [*cat.params, *cat.values]:
        if rec["key"] is None and (rec["family"], rec["path"]) not in known and "." in rec["path"]:
            rec["path"], rec["key"] = rec["path"].rsplit(".", 1)
    values, vseen = [], set()
    for v in cat.values:
        sig = (v["family"], v["path"], v["variant"], v["key"])
        if v["key"] and sig not in vseen:
            vseen.add(sig)
            values.append(v)
    params, seen = [], set()
    for p in cat.params:
        sig = (p["family"], p["path"], p["variant"], p["key"], p["name"], p["meaning"])
        if p["family"] is not None and sig not in seen:
            seen.add(sig)
            params.append(p)
    for p in params:
        p["unit"] = cat.final.get((p["family"], p["name"]), p["unit"])
    return {"tables": tables, "params": params, "values": values, "counts": counts, **extra}


if __name__ == "__main__":
    root = Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
    json.dump(collect(root), sys.stdout, indent=1, sort_keys=True)
