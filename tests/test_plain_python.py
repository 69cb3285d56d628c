"""A kernel as plain Python (:func:`escfit.core.kernels.plain_python`): the same numbers as the
compiled kernel, and nothing compiled or loaded for a report's chart."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from escfit.balance.segment import propagate
from escfit.core.kernels import plain_python


def test_plain_python_gives_the_kernels_numbers():
    plain = plain_python(propagate)
    assert not hasattr(plain, "py_func") and not hasattr(plain.__globals__["_ec_es"], "py_func")
    rng = np.random.default_rng(5)
    for y0, v0, tau, h, w2 in rng.uniform([-2, -5, 0, 0, 0.1], [2, 5, 3, 4, 9], (500, 5)):  # also overdamped
        assert plain(y0, v0, tau, h, w2) == propagate(y0, v0, tau, h, w2)


def test_a_chart_from_python_loads_no_compiled_code():
    code = ("from escfit.balance.monday import charts\n"
            "from escfit.balance import segment\n"
            "x = charts.graph_factor(0.1)\n"
            "print(x > 0, len(segment.propagate.overloads), len(segment._ec_es.overloads))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["True", "0", "0"]
