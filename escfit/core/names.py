"""Parameters' plain names and symbols, as people say them: ``viscous.C`` -> "viscous damping C".

Results files, JSON and the command line's summary keep escfit's code names (``viscous.C``,
``coulomb.R[load=330.66]``); reports show the plain name with its symbol and keep the code
name in a small column.  One table, :data:`NAMES`, maps a code name (a regular expression
matched against the whole name) to a plain name; ``{i}`` and ``{load}`` are filled from the
name's window number and fixture load.  A name the table does not know falls back to the first
clause of the parameter's stored meaning, else to the code name itself.

Sign conventions shown with the names
-------------------------------------
``observation.offset`` is stored as the position of the scale's zero in the oscillator's frame
(a reading is ``theta - offset``), so the centre of the swing *on the sensor's scale* is
``-offset``; reports show that centre, and its drift ``-offset_rate``, because that is what the
record's notes and the figures show (see :func:`centre_sign`).
"""

from __future__ import annotations

import re

__all__ = ["NAMES", "plain_name", "centre_sign", "symbol_of", "scene_key"]

# (pattern, plain name with symbol); first match wins
NAMES: tuple[tuple[str, str], ...] = (
    (r"oscillator\.omega0", "natural frequency ω0"),
    (r"oscillator\.theta0", "release angle θ0"),
    (r"viscous\.C", "viscous damping C"),
    (r"viscous_drift\..*", "growth of viscous damping with the band"),
    (r"coulomb\.R", "Coulomb friction R"),
    (r"coulomb\.R\[load=(?P<load>[^\]]+)\]", "Coulomb friction R at {load}"),
    (r"escapement\[(?P<i>\d+)\]\.X", "escapement torque X{i}"),
    (r"escapement\[(?P<i>\d+)\]\.eps", "unlock ratio ε{i}"),
    (r"hairspring\.omega0\[(?P<i>\d+)\]", "hairspring piece {i}: natural frequency ω{i}"),
    (r"banking\.e", "banking restitution e"),
    (r"observation\.sigma", "reading noise σ"),
    (r"observation\.sigma_t", "beat timing noise σt"),
    (r"observation\.offset", "centre of the swing on the sensor's scale θc"),
    (r"observation\.offset_rate", "drift of the centre dθc/dt"),
    (r"observation\.t_release", "release instant t0"),
    (r"observation\.t0", "release instant t0"),
    (r"observation\.rho", "noise correlation ρ (sample to sample)"),
    (r"observation\.nu", "Student-t degrees of freedom ν"),
    (r"observation\.lift_angle", "true lift angle λ"),
    (r"fit\.kappa", "growth of friction with load κ"),
    (r"fit\.mu", "pivot friction coefficient μ"),
    (r"K", "Monday's combined K"),
    (r"rig\.k", "wire to contact point k"),
    (r"rig\.d", "wire height above the disc d"),
    (r"rig\.lever_ratio", "lever ratio k/d"),
    (r"friction\.mu", "friction coefficient μ"),
    (r"friction\.mu_w", "change of μ with load dμ/dw"),
    (r"friction\.mu_v", "change of μ with speed dμ/dv"),
    (r"geneva\.mu", "pin-slot friction coefficient μ"),
    (r"geneva\.torque", "driving torque K"),
    (r"geneva\.torque_scale", "torque factor s (on every run's K)"),
    (r"geneva\.driver_inertia", "pin-wheel inertia Id"),
    (r"geneva\.follower_inertia", "slotted-wheel inertia If"),
    (r"geneva\.time_scale", "time scale √(If/K)"),
    (r"verge\.mu", "gear-train friction coefficient μ"),
    (r"verge\.mu1", "verge friction coefficient μ1"),
    (r"verge\.restitution", "impact restitution e"),
)

# a record of another quantity than an angle (an angular velocity, a linear displacement) says so in
# the parameter's stored meaning: (name, words in the meaning, plain name)
BY_MEANING: tuple[tuple[str, str, str], ...] = (
    ("oscillator.theta0", "displacement", "release displacement x0"),
    ("observation.offset", "angular velocity", "zero of the rate on the sensor's scale (its bias) b"),
    ("observation.offset_rate", "rad/s**2", "drift of the rate's zero db/dt"),
    ("observation.offset", "displacement", "centre of the swing on the sensor's scale xc"),
    ("observation.offset_rate", "(m/s)", "drift of the centre dxc/dt"),
)

_COMPILED = tuple((re.compile(p + r"\Z"), text) for p, text in NAMES)
_SYMBOL = re.compile(r"\s(\S+)$")
_UNIT_TAIL = re.compile(r",\s*(rad|deg|m|kg|s|N|kg\*m\^2|kg\*m\*\*2|N\*m|rad/s|1/s)$")


def plain_name(name: str, meaning: str = "", loads_in: str = "", kind: str = "") -> str:
    """The plain name and symbol of parameter ``name`` (see the module docstring).

    Parameters
    ----------
    name
        Code name, e.g. ``"coulomb.R[load=330.66]"``.
    meaning
        Its stored meaning (a fallback, and for escapement windows: unlock or impulse).
    loads_in
        Unit of fixture loads (``"g"``), appended to a load.
    kind
        The reading kind of the fit; the noise of a friction rig's ``dw`` or of turns to arm
        keeps the generic name.

    Examples
    --------
    >>> plain_name("viscous.C")
    'viscous damping C'
    >>> plain_name("coulomb.R[load=330.66]", loads_in="g")
    'Coulomb friction R at 330.66 g'
    """
    for code, words, text in BY_MEANING:
        if name == code and words in meaning:
            return text
    for pattern, text in _COMPILED:
        found = pattern.match(name)
        if not found:
            continue
        groups = found.groupdict()
        if "load" in groups:
            groups["load"] = f"{groups['load']} {loads_in}".strip()
        out = text.format(**groups)
        if name.startswith("escapement[") and name.endswith(".X"):
            words = meaning.lower()
            out = ("unlocking torque" if "unlock" in words else "impulse torque" if "impulse" in words
                   else "escapement torque") + f" X{groups['i']} (window {groups['i']})"
        return out
    first = meaning.split(";")[0].split("(")[0].strip().rstrip(",")
    first = _UNIT_TAIL.sub("", first)  # "... from its pivot, kg*m^2": the unit column says it
    return first or name


def symbol_of(plain: str) -> str:
    """The symbol at the end of a plain name (``"viscous damping C"`` -> ``"C"``), or ``""``."""
    found = _SYMBOL.search(plain)
    return found.group(1) if found and len(found.group(1)) <= 8 else ""


def centre_sign(name: str) -> float:
    """-1 for the stored zero offset and its drift (shown as the centre and its drift), else +1."""
    return -1.0 if name in ("observation.offset", "observation.offset_rate") else 1.0


# Tables a parameter's prefix names directly; every other prefix is an effect, [effects.<prefix>]
_OWN_TABLES = ("oscillator", "observation", "geneva", "friction", "rig")


def scene_key(name: str) -> str:
    """Where a parameter is written in a scene: ``viscous.C`` -> ``[effects.viscous] C``.

    ``escapement[2].X`` -> ``[[effects.escapement]] number 2, X``; ``oscillator.theta0`` ->
    ``[oscillator] theta0``; a fixture load's suffix (``[load=330.66]``) is dropped.  Used by
    messages that ask for an edit of the scene.
    """
    base = re.sub(r"\[load=[^\]]*\]", "", name)
    found = re.fullmatch(r"escapement\[(\d+)\]\.(\w+)", base)
    if found:
        return f"[[effects.escapement]] number {found.group(1)}, {found.group(2)}"
    table, _, key = base.partition(".")
    if not key:
        return base
    if table == "fit":  # the load rule's parameters (fit.kappa, fit.mu)
        return f"[fit.loads] {key}"
    if table == "verge":  # the verge reads its keys from [verge] and its sub-tables
        return f"[verge] (or its sub-table holding it) {key}"
    return f"[{table}] {key}" if table in _OWN_TABLES else f"[effects.{table}] {key}"
