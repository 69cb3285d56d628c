"""Observation models: how a recorder turns the true motion into readings.

They are separate from the physics: each takes the model's signed turning-point angles
``theta_turn`` (rad) and the readings, and has its own documented noise parameters named
``observation.<name>``.
"""

from __future__ import annotations

from typing import Any, Mapping

from ...core.errors import SceneError
from ...core.scene import check_keys
from ...core.suggest import did_you_mean
from .amplitude import AmplitudeObservation
from .notches import NotchObservation

__all__ = ["AmplitudeObservation", "NotchObservation", "observation_from_table"]

_KINDS = {"amplitude": AmplitudeObservation, "notches": NotchObservation}


def observation_from_table(table: Mapping[str, Any] | None, where: str, data_kind: str, notch: float | None = None):
    """Build the observation model a scene's ``[observation]`` table describes.

    Parameters
    ----------
    table
        The table, or ``None`` for the default for ``data_kind``.
    where
        Scene file name for messages.
    data_kind
        ``"amplitude"`` or ``"notches"``: what the data file holds; must agree.
    notch
        Notch angle of the data (rad), used when the table gives none.
    """
    table = dict(table or {})
    w = f"{where} [observation]"
    model = table.pop("model", data_kind)
    if model not in _KINDS:
        raise SceneError(f"observation model {model!r}{did_you_mean(model, _KINDS)} does not apply to these data: "
                         f"{data_kind} readings are fitted with one of {sorted(_KINDS)}", f"{w}.model")
    if model != data_kind:
        raise SceneError(f"observation model {model!r} does not match the data, which hold {data_kind} readings", w)
    cls = _KINDS[model]
    check_keys(table, cls.KEYS | {"model"}, w)  # model was read above: named among the keys a typo may mean
    return cls.from_table(table, w, notch=notch)
