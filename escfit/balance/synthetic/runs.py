"""What a synthetic recorder may record: a run the solver finished."""

from __future__ import annotations

from ...core.errors import SceneError
from ..scene import BalanceScene
from ..trajectory import Trajectory

__all__ = ["complete"]


def complete(tr: Trajectory, scene: BalanceScene) -> Trajectory:
    """``tr`` if the solver finished the run; a run cut short (out of segments, failed) would be
    recorded as a shorter recording of another balance, so it is refused."""
    if tr.status in ("max_segments", "failed"):
        raise SceneError(f"the scene's run ends with status {tr.status!r} after {tr.amplitude.size} half swing(s) "
                         f"({tr.message or 'the solver did not finish it'}): nothing to record", scene.where)
    return tr
