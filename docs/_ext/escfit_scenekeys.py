"""Sphinx extension: the scene-key reference, generated from escfit's scene readers.

At ``builder-inited`` it runs ``scenekeys_collect.py`` in a separate process (which watches
the readers read every shipped scene and probes the keys no shipped file uses), renders the
catalogue as Markdown into ``reference/_scene_keys.md`` and lets ``reference/scene-keys.md``
include it.  That file is kept in the repository, so that the reference reads as Markdown on
its own; ``tests/test_docs_scene_keys.py`` checks that it matches the code (regenerate it with
``python docs/_ext/escfit_scenekeys.py``).  The catalogue is cached beside the build, keyed by the contents of escfit's
sources, the shipped scenes and this folder, so an unchanged tree is not read again.

Descriptions come from the code (a parameter's declared meaning, an effect's docstring, the
``RecordingSpec`` attributes, the ``escfit fit`` options' help); keys that carry none in the
code take theirs from ``reference/scene-keys-glossary.toml``.  A glossary entry for a key the
code no longer allows, or a model family with no tables found, is a build warning.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import subprocess
import sys
import tomllib
from pathlib import Path

try:  # the test that the committed reference matches the code imports this module without Sphinx
    from sphinx.util import logging

    logger = logging.getLogger(__name__)
except ImportError:
    import logging

    logger = logging.getLogger(__name__)

HERE = Path(__file__).resolve().parent
TOP = "(top)"
ORDER = ["oscillator", "rig", "friction", "geneva", "verge", "run", "effects", "observation", "recording", "fit"]
FAMILY_TITLES = {"balance": "Balance wheels and pendulums", "friction_rig": "The friction rig",
                 "geneva": "Geneva escapements", "verge": "Verge escapements"}


# --- collecting --------------------------------------------------------------------------------

def _fingerprint(root: Path) -> str:
    h = hashlib.sha256()
    files = [*sorted((root / "escfit").rglob("*.py")), *sorted((root / "datasets").rglob("*.toml")),
             *sorted((root / "fits").rglob("*.toml")), *sorted(HERE.glob("*.py")),
             HERE.parent / "reference" / "scene-keys-glossary.toml"]
    for f in files:
        if f.is_file():
            h.update(str(f.relative_to(root)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def collect(root: Path, cache: Path) -> dict:
    key = _fingerprint(root)
    if cache.is_file():
        try:
            stored = json.loads(cache.read_text(encoding="utf-8"))
            if stored.get("fingerprint") == key:
                return stored["catalogue"]
        except (OSError, ValueError):
            pass
    proc = subprocess.run([sys.executable, str(HERE / "scenekeys_collect.py"), str(root)], capture_output=True,
                          text=True, timeout=600, cwd=root)
    if proc.returncode != 0:
        raise RuntimeError(f"scene-key collection failed:\n{proc.stderr[-3000:]}")
    catalogue = json.loads(proc.stdout)
    if catalogue.get("counts", {}).get("key_probes", 0) < 0:
        logger.warning("scene keys: the probes of unused keys ran out of time; the reference is incomplete")
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps({"fingerprint": key, "catalogue": catalogue}), encoding="utf-8")
    return catalogue


# --- rendering ---------------------------------------------------------------------------------

def _unit(u: str) -> str:
    if not u:
        return "–"
    return u.replace("**2", "²").replace("**3", "³").replace("**-1", "⁻¹").replace("*", " ")


def _bound(x) -> float:
    return {"inf": math.inf, "-inf": -math.inf}.get(x, x) if isinstance(x, str) else float(x)


def _fmt(x: float) -> str:
    for mult, name in ((math.pi, "π"), (2 * math.pi, "2π"), (math.pi / 2, "π/2"), (4 * math.pi, "4π")):
        if abs(abs(x) - mult) < 1e-12:
            return ("-" if x < 0 else "") + name
    return f"{x:g}"


def _range(p: dict) -> str:
    lo, hi, open_ = _bound(p["lower"]), _bound(p["upper"]), p["lower_open"]
    if math.isinf(lo) and math.isinf(hi):
        text = "any"
    elif math.isinf(hi):
        text = f"{'>' if open_ else '≥'} {_fmt(lo)}"
    elif math.isinf(lo):
        text = f"≤ {_fmt(hi)}"
    else:
        text = f"{'(' if open_ else '['}{_fmt(lo)}, {_fmt(hi)}]"
    if p.get("bare_limit") not in (None, "inf"):
        text += f"; a bare number at most {_fmt(_bound(p['bare_limit']))}"
    return text


def _cell(text: str) -> str:
    """One table cell: one line, pipes escaped, docstring roles (:data:`~x.y`) as plain code."""
    text = re.sub(r":[\w:]+:`~?([^`]+)`", r"`\1`", " ".join(str(text).split()))
    return text.replace("|", "\\|")


class Renderer:
    def __init__(self, cat: dict, glossary: dict, fit_help: dict[str, str]):
        self.cat, self.glossary, self.fit_help = cat, glossary, fit_help
        self.undescribed: list[str] = []
        self.params: dict[tuple, list[dict]] = {}
        for p in cat["params"]:
            self.params.setdefault((p["family"], p["path"], p["key"]), []).append(p)
        self.values = {(v["family"], v["path"], v["key"]): v for v in cat.get("values", [])}
        self.tables: dict[tuple, list[dict]] = {}
        for t in cat["tables"]:
            self.tables.setdefault((t["family"], t["path"]), []).append(t)
        effects = cat.get("effects", {})
        if effects:  # the [effects] table is the registry itself
            self.tables.setdefault(("balance", "effects"), []).append(
                {"family": "balance", "path": "effects", "variant": None, "allowed": list(effects), "required": [],
                 "array": False, "source": "balance/effects/__init__.py:EFFECTS"})

    def describe(self, family: str, path: str, key: str) -> str:
        if family == "balance" and path == "effects" and key in self.cat.get("effects", {}):
            return self.cat["effects"][key].replace("``", "`")
        if family == "balance" and path == "recording":
            doc = self.cat.get("recording", {}).get("doc", {}).get(key)
            if doc:
                return doc.replace("``", "`")
        if family == "(recipe)" and self.fit_help.get(key):
            return self.fit_help[key]
        return self.glossary.get(family, {}).get(path or TOP, {}).get(key, "")

    def rows(self, family: str, path: str, keys: list[str], required: set[str], variant: str | None = None) -> list[str]:
        """A table of the keys: five columns where some key has a unit or a parameter, else two."""
        body, rich = [], False
        for key in keys:
            name = f"`{key}`" + (" (required)" if key in required else "")
            ps = self.params.get((family, path, key), [])
            if variant is not None:
                ps = [p for p in ps if p.get("variant") in (variant, None)]
            if ps:
                rich = True
                for p in ps:
                    unit = _unit(p["unit"])
                    if p.get("converted") and p.get("input_unit") and p["input_unit"] != p["unit"]:
                        unit = f"read in {_unit(p['input_unit'])}, kept as {unit}"
                    meaning = p["meaning"] or self.describe(family, path, key)
                    which = f" (`model = \"{p['variant']}\"`)" if p.get("variant") and len(ps) > 1 else ""
                    body.append((name, f"`{p['name']}`{which}", unit, _range(p), _cell(meaning)))
                    name = ""
                continue
            text = self.describe(family, path, key)
            if not text:
                self.undescribed.append(f"{family} [{path or TOP}] {key}")
                text = "*not described yet*"
            v = self.values.get((family, path, key))
            rich = rich or v is not None
            body.append((name, "", _unit(v["unit"]) if v else "", "", _cell(text)))
        if rich:
            out = ["| key | parameter | unit | allowed | meaning |", "|---|---|---|---|---|"]
            out += [f"| {' | '.join(row)} |" for row in body]
        else:
            out = ["| key | meaning |", "|---|---|"] + [f"| {row[0]} | {row[4]} |" for row in body]
        return out

    def family(self, family: str) -> list[str]:
        tables = {p: ts for (f, p), ts in self.tables.items() if f == family}
        if not tables:
            logger.warning(f"scene keys: no tables found for model {family!r}; the collector read none of its scenes")
            return []
        title = FAMILY_TITLES.get(family, family)
        lines = [f"## {title}: `model = \"{family}\"`", ""]

        def order(path: str):
            root = path.split(".")[0]
            return (path != "", ORDER.index(root) if root in ORDER else len(ORDER), path.count("."), path)

        for path in sorted(tables, key=order):
            ts = tables[path]
            variants = [t for t in ts if t["variant"]]
            groups = [(t["variant"], t) for t in sorted(variants, key=lambda t: t["variant"])] or [(None, ts[0])]
            for variant, t in groups:
                allowed = set(t["allowed"])
                if variant is None:
                    for other in ts:
                        allowed |= set(other["allowed"])
                required = set(t["required"])
                shown = f"[[{path}]]" if t["array"] else f"[{path}]"
                head = "### Top level" if path == "" else (
                    f"### `{shown}`" + (f" with `model = \"{variant}\"`" if variant else ""))
                lines += [head, ""]
                src = t.get("source", "")
                if src:
                    lines += [f"Read by `escfit/{src.split(':')[0]}`.", ""]
                keys = sorted(allowed - {"model"}) if variant else sorted(allowed)
                if variant:
                    keys = ["model", *keys]  # the key that chose this table's keys
                lines += self.rows(family, path, keys, required, variant) + [""]
        return lines

    def render(self) -> str:
        lines = []
        models = self.cat.get("models") or ["balance", "friction_rig", "geneva", "verge"]
        for family in models:
            lines += self.family(family)
        recipe = self.tables.get(("(recipe)", "(recipe)"))
        if recipe:
            t = recipe[0]
            lines += ["## Fit recipes: `escfit fit RECIPE.toml`", "",
                      "A recipe names the data and the scene (paths relative to the recipe) and the options of "
                      "`escfit fit`; options given on the command line win. The meanings are the command's own "
                      "option help.", ""]
            lines += self.rows("(recipe)", "(recipe)", sorted(t["allowed"]), set(t["required"])) + [""]
        keys = self.cat.get("param_table_keys", [])
        if keys:
            lines += ["## A free parameter's table", "",
                      "Any parameter above may be written as a table, e.g. "
                      "`C = { value = 0.8, vary = true, min = 0, max = 5, prior = \"lognormal(0, 1)\" }`:", ""]
            lines += ["| key | meaning |", "|---|---|"]
            for key in keys:
                text = self.glossary.get("(parameter)", {}).get(key, "")
                if not text:
                    self.undescribed.append(f"parameter table: {key}")
                    text = "*not described yet*"
                lines.append(f"| `{key}` | {_cell(text)} |")
            lines.append("")
        c = self.cat.get("counts", {})
        lines += ["```{admonition} How this page was made", ":class: note", "",
                  f"Generated when the site was built, by watching escfit's readers read {c.get('scenes', 0)} "
                  f"shipped scenes, {c.get('recipes', 0)} fit recipes and {c.get('pairs', 0)} scene-recording "
                  f"pairs, and by {abs(c.get('key_probes', 0)) + c.get('effect_probes', 0) + c.get('table_probes', 0)} "
                  "probes of keys that no shipped file uses (`docs/_ext/scenekeys_collect.py`). "
                  "Descriptions of keys that are not parameters: `docs/reference/scene-keys-glossary.toml`.",
                  "```", ""]
        return "\n".join(lines)

    def stale_glossary(self) -> list[str]:
        stale = []
        allowed: dict[tuple, set] = {}
        for (f, p), ts in self.tables.items():
            for t in ts:
                allowed.setdefault((f, p or TOP), set()).update(t["allowed"])
        for family, tables in self.glossary.items():
            if family in ("(parameter)", "(recipe)"):
                continue
            for path, keys in tables.items():
                for key in keys:
                    if key not in allowed.get((family, path), set()):
                        stale.append(f"{family} [{path}] {key}")
        return stale


def _fit_help() -> dict[str, str]:
    """Recipe key -> the help of the matching ``escfit fit`` option."""
    try:
        from escfit.cli.main import cli
    except Exception:
        return {}
    cmd = cli.commands.get("fit")
    out = {}
    for p in getattr(cmd, "params", []):
        for opt in [*getattr(p, "opts", []), p.name or ""]:
            key = opt.lstrip("-").replace("-", "_").lower()
            text = getattr(p, "help", None) or ("The recording to fit." if key == "data" else "")
            if text and key not in out:
                out[key] = text
    return out


def render(root: Path, cache: Path) -> tuple[str, "Renderer"]:
    """The scene-key tables of the checkout at ``root`` as Markdown, and the renderer (for its
    warnings); ``cache`` keeps the collected catalogue between runs."""
    docs = root / "docs"
    cat = collect(root, cache)
    glossary = tomllib.loads((docs / "reference" / "scene-keys-glossary.toml").read_text(encoding="utf-8"))
    r = Renderer(cat, glossary, _fit_help())
    return r.render(), r


def generate(app) -> None:
    """Write ``reference/_scene_keys.md`` (kept in the repository, so that the page reads as
    Markdown too) when the code's tables differ from it."""
    docs = Path(app.srcdir)
    text, r = render(docs.parent, Path(app.doctreedir) / "scenekeys-cache.json")
    for item in r.stale_glossary():
        logger.warning(f"scene keys: the glossary describes {item}, which no reader allows "
                       "(docs/reference/scene-keys-glossary.toml)")
    if r.undescribed:
        logger.info(f"scene keys not described yet: {', '.join(r.undescribed)}")
    out = docs / "reference" / "_scene_keys.md"
    if not out.is_file() or out.read_text(encoding="utf-8") != text:
        out.write_text(text, encoding="utf-8")


def setup(app):
    app.connect("builder-inited", generate)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}


if __name__ == "__main__":  # python docs/_ext/escfit_scenekeys.py: rewrite the committed tables
    import tempfile

    top = HERE.parents[1]
    with tempfile.TemporaryDirectory() as tmp:
        tables, _ = render(top, Path(tmp) / "cache.json")
    (top / "docs" / "reference" / "_scene_keys.md").write_text(tables, encoding="utf-8")
    print("wrote docs/reference/_scene_keys.md")
