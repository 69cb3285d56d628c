"""The sampler's checkpoint: every draw so far and the random state, written in chunks.

A run of emcee is saved every few seconds (not every step) to ``<out>.emcee``, an HDF5 file
holding the chain, the log posterior, each walker's accepted-proposal count and the state of
emcee's random generator *after the last saved step*.  Continuing from it therefore draws
exactly what the uninterrupted run would have drawn.  Each save writes a temporary file
beside the target and renames it over the old checkpoint, so a kill at any moment leaves
either the previous checkpoint or the new one, never a torn file: at most the steps since the
last save are lost.  Datasets carry HDF5 checksums (fletcher32), so a damaged file is refused
instead of being continued.

Layout (format ``escfit-emcee-checkpoint``, version 1)::

    /chain      float64 (steps, walkers, ndim)
    /log_prob   float64 (steps, walkers)
    /accepted   int64   (walkers,)
    /mt_keys    uint32  (624,)          numpy MT19937 key of emcee's RandomState
    attrs: format, version, names (JSON), seed, moves, mt_pos, mt_has_gauss, mt_gauss
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import ResultsError

__all__ = ["Checkpoint", "save_checkpoint", "load_checkpoint", "FORMAT"]

FORMAT = "escfit-emcee-checkpoint"
VERSION = 1


@dataclass
class Checkpoint:
    """What a resumed run needs.

    Attributes
    ----------
    chain : ndarray, shape (steps, walkers, ndim)
    log_prob : ndarray, shape (steps, walkers)
    accepted : ndarray, shape (walkers,)
        Accepted proposals per walker over all ``steps``.
    random_state : tuple
        ``numpy.random.RandomState.get_state()`` after the last stored step.
    names : list of str
        Free parameters in vector order.
    seed : int
    moves : str
    """

    chain: np.ndarray
    log_prob: np.ndarray
    accepted: np.ndarray
    random_state: tuple
    names: list[str]
    seed: int
    moves: str

    @property
    def steps(self) -> int:
        return int(self.chain.shape[0])


def save_checkpoint(path: str | Path, ck: Checkpoint) -> None:
    """Write ``ck`` to ``path`` atomically (temporary file beside it, then rename).

    The HDF5 image is built in memory and written in one piece
    (:func:`escfit.core.h5write.write_bytes`), so a full disk is one clear error and never
    leaves a partial file or damages the previous checkpoint.
    """
    import io

    import h5py

    from ..core.h5write import write_bytes

    target = Path(path)
    name, keys, pos, has_gauss, gauss = ck.random_state
    if name != "MT19937":
        raise ResultsError(f"cannot checkpoint a random generator of kind {name!r}", str(target))
    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        kw = {"fletcher32": True} if ck.chain.size else {}
        f.create_dataset("chain", data=ck.chain, **kw)
        f.create_dataset("log_prob", data=ck.log_prob, **kw)
        f.create_dataset("accepted", data=np.asarray(ck.accepted, np.int64))
        f.create_dataset("mt_keys", data=np.asarray(keys, np.uint32), fletcher32=True)
        f.attrs.update({"format": FORMAT, "version": VERSION, "names": json.dumps(list(ck.names)),
                        "seed": int(ck.seed), "moves": str(ck.moves), "mt_pos": int(pos),
                        "mt_has_gauss": int(has_gauss), "mt_gauss": float(gauss)})
    write_bytes(buf.getvalue(), target, force=True)


def load_checkpoint(path: str | Path, walkers: int, names: list[str]) -> Checkpoint:
    """Read a checkpoint for a run of ``walkers`` walkers over ``names``.

    Raises
    ------
    ResultsError
        Missing, damaged or foreign file, or one of another shape or parameter set (the
        message names the way out: ``--force`` starts again).
    """
    import h5py

    where = str(path)
    if not Path(path).exists():
        raise ResultsError("nothing to resume: checkpoint file not found", where)
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT:
                raise ResultsError("not an escfit sampler checkpoint (written by another program or an older "
                                   "version); pass --force to start again", where)
            ck = Checkpoint(f["chain"][()], f["log_prob"][()], f["accepted"][()],
                            ("MT19937", f["mt_keys"][()], int(f.attrs["mt_pos"]), int(f.attrs["mt_has_gauss"]),
                             float(f.attrs["mt_gauss"])),
                            list(json.loads(f.attrs["names"])), int(f.attrs["seed"]), str(f.attrs["moves"]))
    except ResultsError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:  # truncated, checksum failure, missing parts
        raise ResultsError(f"cannot resume from this checkpoint ({type(exc).__name__}: {exc}); pass --force to "
                           "start again", where) from None
    shape = ck.chain.shape
    if (len(shape) != 3 or shape[0] < 1 or ck.log_prob.shape != shape[:2] or ck.accepted.shape != (shape[1],)
            or ck.random_state[1].shape != (624,) or not 0 <= ck.random_state[2] <= 624):
        raise ResultsError(f"damaged checkpoint (chain {shape}, log_prob {ck.log_prob.shape}); pass --force to "
                           "start again", where)
    if shape[1:] != (walkers, len(names)):
        raise ResultsError(f"checkpoint holds {shape[1]} walkers x {shape[2]} parameters, this fit has "
                           f"{walkers} x {len(names)}; pass --force to start again", where)
    if ck.names != list(names):
        raise ResultsError(f"checkpoint is of a fit of {ck.names}, this fit has {list(names)}; pass --force to "
                           "start again", where)
    return ck
