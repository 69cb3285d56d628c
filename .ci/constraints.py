"""Write .ci/constraints.txt: the versions installed now of escfit's dependency closure, pinned.

The closure is every distribution reachable from pyproject.toml's dependencies and the extras
CI installs or tests use (test, study, plot, bench), following each installed distribution's
own requirements (with their markers and extras evaluated for this interpreter).  Run it in an
environment where the suite passes; CI installs with ``-c .ci/constraints.txt`` so that a run
is reproducible, and runs the suite once more against the newest versions pip resolves
(``.ci/newest``) to see upstream drift before users do.

Usage (from the repository root, in the environment to pin)::

    python .ci/constraints.py > .ci/constraints.txt
"""

from __future__ import annotations

import importlib.metadata as md
import platform
import re
import sys
import tomllib
from pathlib import Path

from packaging.markers import default_environment
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]
EXTRAS = ("test", "study", "plot", "bench")
# installers and build tools: pinned by nobody (pyproject's build-system asks for its own setuptools)
NOT_PINNED = {"pip", "setuptools", "wheel"}


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def closure() -> dict[str, str]:
    """Normalised name -> installed version, for the whole dependency closure."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = list(project["dependencies"]) + [r for e in EXTRAS for r in project["optional-dependencies"][e]]
    env = default_environment()
    stack = [Requirement(r) for r in wanted]
    seen: set[tuple[str, frozenset]] = set()
    out: dict[str, str] = {}
    while stack:
        req = stack.pop()
        key = (_norm(req.name), frozenset(req.extras))
        if key in seen:
            continue
        seen.add(key)
        try:
            dist = md.distribution(req.name)
        except md.PackageNotFoundError:
            sys.exit(f"{req.name} is not installed here: install escfit[{','.join(EXTRAS)}] first")
        out[key[0]] = f"{dist.metadata['Name']}=={dist.version}"
        for text in dist.requires or []:
            sub = Requirement(text)
            if sub.marker is None or any(sub.marker.evaluate({**env, "extra": e}) for e in (req.extras or {""})):
                stack.append(sub)
    return {k: v for k, v in out.items() if k not in NOT_PINNED}


def main() -> None:
    pins = closure()
    print(f"# escfit's dependency closure as installed when the suite passed (python .ci/constraints.py);\n"
          f"# Python {platform.python_version()} on {platform.system()} {platform.machine()}.  CI installs with\n"
          f"# pip install -c .ci/constraints.txt; .ci/newest runs the suite against the newest versions.")
    for key in sorted(pins):
        print(pins[key])


if __name__ == "__main__":
    main()
