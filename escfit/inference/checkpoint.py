"""The sampler's checkpoint: every draw so far and the random state, written in chunks.

A run of emcee is saved every few seconds (not every step) to ``<out>.emcee``, an HDF5 file
holding the chain, the log posterior, each walker's accepted-proposal count and the state of
emcee's random generator *after the last saved step*.  Continuing from it therefore draws
exactly what the uninterrupted run would have drawn.  Each save writes a temporary file
beside the target and renames it over the old checkpoint, so a kill at any moment leaves
either the previous checkpoint or the new one, never a torn file: at most the steps since the
last save are lost.  Datasets carry HDF5 checksums (fletcher32), so a damaged file is refused
instead of being continued.

A checkpoint resumes only the run it belongs to: it records the run's identity (the data's
SHA-256, a hash of the scene text, the family's options, walkers, moves and seed; see
:func:`run_identity`), and a resume whose identity differs is refused with the first
difference named.  What it holds is checked before it is used, checksums or not: finite
draws, a generator state numpy can continue from (an all-zero key would hang it), counts
within the run, moves that agree with the accepted counts and walkers that stood still with
their log-probabilities unchanged (:func:`_check_moves`).  The draws of every step against
the bounds, and the log-probabilities of five steps against the posterior, are checked by
:func:`escfit.inference.mcmc.resumable`, which has the problem.

The chain and log-probabilities are the sampler's own: in the coordinates it moves in
(:mod:`escfit.inference.space`; ``coordinates`` names them, ``"identity"`` for the problem's
parameters) and with its log density there, so that they round-trip exactly.

Layout (format ``escfit-emcee-checkpoint``, version 3)::

    /chain      float64 (steps, walkers, ndim)   in the sampler's coordinates
    /log_prob   float64 (steps, walkers)         the sampler's log density
    /accepted   int64   (walkers,)
    /mt_keys    uint32  (624,)          numpy MT19937 key of emcee's RandomState
    attrs: format, version, names (JSON), seed, moves, mt_pos, mt_has_gauss, mt_gauss, identity (JSON),
           coordinates

Version 2 (without ``coordinates``) was written before sampler coordinates existed: its draws
are in the problem's parameters and it is read as ``coordinates = "identity"``.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..core.errors import ResultsError

__all__ = ["Checkpoint", "save_checkpoint", "load_checkpoint", "check_identity", "run_identity", "FORMAT"]

FORMAT = "escfit-emcee-checkpoint"
VERSION = 3  # 2: the run's identity is recorded and compared on resume; 3: the sampler's coordinates named
READABLE = (2, 3)
# Provenance entries that name where things were, not what they were (a moved file is the same run)
LOCATIONS = ("scene_file", "data_file")


def run_identity(provenance: Mapping[str, Any] | None = None, options: Mapping[str, Any] | None = None, *,
                 walkers: int, moves: str, seed: int, names: list[str]) -> dict[str, str]:
    """What makes two sampler runs the same run, as text: compared entry by entry on resume.

    Parameters
    ----------
    provenance
        The problem's :meth:`~escfit.likelihood.problem.Problem.provenance`: its ``data_sha256``
        and the SHA-256 of its ``scene`` text are recorded, and every other entry but the files'
        locations (moving the files does not change the run).
    options
        The options the problem was built with (recording format, unit, solver, ...).
    walkers, moves, seed, names
        The sampler's settings and the free parameters in vector order.
    """
    prov = dict(provenance or {})
    scene = prov.pop("scene", None)
    ident = {"data SHA-256": str(prov.pop("data_sha256", None)),
             "scene text (SHA-256)": hashlib.sha256(str(scene).encode()).hexdigest() if scene is not None else "None",
             "free parameters": json.dumps(list(names)), "walkers": str(int(walkers)), "moves": str(moves),
             "seed": str(int(seed))}
    for key in LOCATIONS:
        prov.pop(key, None)
    canonical = lambda x: json.dumps(x, sort_keys=True, default=str)  # noqa: E731
    ident["model options"] = canonical(prov)
    ident["fit options"] = canonical(dict(options or {}))
    return ident


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
    identity : dict
        :func:`run_identity` of the run.
    coordinates : str
        The sampler coordinates ``chain`` and ``log_prob`` are in
        (:attr:`escfit.inference.space.SamplerSpace.name`; ``"identity"``: the problem's parameters).
    """

    chain: np.ndarray
    log_prob: np.ndarray
    accepted: np.ndarray
    random_state: tuple
    names: list[str]
    seed: int
    moves: str
    identity: dict = field(default_factory=dict)
    coordinates: str = "identity"

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
                        "mt_has_gauss": int(has_gauss), "mt_gauss": float(gauss),
                        "identity": json.dumps(dict(ck.identity), sort_keys=True),
                        "coordinates": str(ck.coordinates)})
    write_bytes(buf.getvalue(), target, force=True)


def load_checkpoint(path: str | Path, walkers: int, names: list[str],
                    identity: Mapping[str, str] | None = None) -> Checkpoint:
    """Read a checkpoint for a run of ``walkers`` walkers over ``names``.

    Parameters
    ----------
    identity
        :func:`run_identity` of the run that wants to resume: every entry must equal the
        checkpoint's.

    Raises
    ------
    ResultsError
        Missing, damaged or foreign file, one of another shape or parameter set, or of
        another run (the message names the first difference and the way out: ``--force``
        starts again).
    """
    import h5py

    where = str(path)
    if not Path(path).exists():
        raise ResultsError("nothing to resume: checkpoint file not found", where)
    _check_declared(path, walkers, names)
    try:
        with h5py.File(path, "r") as f:
            version = int(f.attrs.get("version", 0))
            ck = Checkpoint(f["chain"][()], f["log_prob"][()], f["accepted"][()],
                            ("MT19937", f["mt_keys"][()], int(f.attrs["mt_pos"]), int(f.attrs["mt_has_gauss"]),
                             float(f.attrs["mt_gauss"])),
                            list(json.loads(f.attrs["names"])), int(f.attrs["seed"]), str(f.attrs["moves"]),
                            dict(json.loads(f.attrs["identity"])),
                            str(f.attrs["coordinates"]) if version >= 3 else "identity")
    except (OSError, KeyError, ValueError, TypeError) as exc:  # truncated, checksum failure, missing parts
        raise ResultsError(f"cannot resume from this checkpoint ({type(exc).__name__}: {exc}); pass --force to "
                           "start again", where) from None
    _check_contents(ck, where)
    shape = ck.chain.shape
    if shape[1:] != (walkers, len(names)):
        raise ResultsError(f"checkpoint holds {shape[1]} walkers x {shape[2]} parameters, this fit has "
                           f"{walkers} x {len(names)}; pass --force to start again", where)
    if ck.names != list(names):
        raise ResultsError(f"checkpoint is of a fit of {ck.names}, this fit has {list(names)}; pass --force to "
                           "start again", where)
    if identity is not None:
        check_identity(ck, identity, where)
    return ck


# The arrays of a checkpoint, the element size each holds, and their shapes for a run of
# ``walkers`` walkers over ``ndim`` parameters (None: the number of steps, any)
ARRAYS = {"chain": (8, lambda walkers, ndim: (None, walkers, ndim)),
          "log_prob": (8, lambda walkers, ndim: (None, walkers)),
          "accepted": (8, lambda walkers, ndim: (walkers,)),
          "mt_keys": (4, lambda walkers, ndim: (624,))}


def _check_declared(path: str | Path, walkers: int, names: list[str]) -> None:
    """Refuse, from the file's metadata alone, a checkpoint that is not this escfit's, or whose
    arrays are missing, declare more than the file holds, or have shapes that disagree with each
    other or with this run (``walkers`` x ``len(names)``): nothing is read before this passes."""
    from ..core import h5layout

    where, again = str(path), "; pass --force to start again"
    try:
        layout = h5layout.read_layout(path, "cannot resume from this checkpoint")
        if layout.attrs.get("format") != FORMAT:
            raise ResultsError("not an escfit sampler checkpoint (written by another program or an older version)",
                               where)
        version = layout.attrs.get("version", 0)
        attrs = ("identity", "names", "seed", "moves", "mt_pos", "mt_has_gauss", "mt_gauss") + (
            ("coordinates",) if version == 3 else ())
        if version not in READABLE or any(a not in layout.attrs for a in attrs):
            raise ResultsError(f"a checkpoint of format version {version} (this escfit writes {VERSION}) cannot be "
                               "checked to belong to this run", where)
        missing = [name for name in ARRAYS if name not in layout.arrays]
        if missing:
            raise ResultsError(f"damaged checkpoint: its {missing[0]} array is missing", where)
        h5layout.check_backed(layout)
        chain = layout.arrays["chain"].shape
        if len(chain) == 3 and chain[1:] != (walkers, len(names)):
            raise ResultsError(f"checkpoint holds {chain[1]} walkers x {chain[2]} parameters, this fit has "
                               f"{walkers} x {len(names)}", where)
        steps = chain[0] if chain else None
        for name, (itemsize, shape) in ARRAYS.items():
            want = tuple(steps if n is None and name != "chain" else n for n in shape(walkers, len(names)))
            h5layout.expect_shape(layout, name, want, " in a checkpoint of this run")
            if layout.arrays[name].itemsize != itemsize:
                raise ResultsError(f"damaged checkpoint: its {name} array holds {layout.arrays[name].itemsize}-byte "
                                   f"values, not {itemsize}-byte ones", where)
    except ResultsError as exc:
        raise ResultsError(f"{exc.message}{again}", where) from None


def check_identity(ck: Checkpoint, identity: Mapping[str, str], where: str) -> None:
    """Refuse ``ck`` unless every entry of ``identity`` (:func:`run_identity`) equals its own,
    naming the first that differs."""
    for key, now in identity.items():
        then = ck.identity.get(key)
        if then != now:
            raise ResultsError(f"the checkpoint belongs to another run: its {key} is {_short(then)}, this run's is "
                               f"{_short(now)}; resume with the same data, scene and options, or pass --force to "
                               "start again", where)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "...'"


def _check_moves(ck: Checkpoint) -> str | None:
    """What contradicts the chain's own record of its moves, or None.

    Between two stored steps a walker either moved (an accepted proposal) or stayed where it
    was with the same log-probability: emcee never changes one without the other.  So a walker
    cannot have moved more often than it had proposals accepted, and one that stood still kept
    its log-probability bit for bit.
    """
    moved = np.any(ck.chain[1:] != ck.chain[:-1], axis=2)
    moves = moved.sum(axis=0)
    if np.any(moves > ck.accepted):
        w = int(np.argmax(moves > ck.accepted))
        return f"walker {w} moved {int(moves[w])} times with {int(ck.accepted[w])} accepted proposals"
    changed = ~moved & (ck.log_prob[1:] != ck.log_prob[:-1])
    if np.any(changed):
        t, w = (int(i[0]) for i in np.nonzero(changed))
        return (f"walker {w} stood still at step {t + 2} of {ck.steps} but its log-probability changed "
                f"from {ck.log_prob[t, w]:.10g} to {ck.log_prob[t + 1, w]:.10g}")
    return None


def _check_contents(ck: Checkpoint, where: str) -> None:
    """Refuse contents no run of escfit can have written (checksums catch damage, not tampering)."""
    shape = ck.chain.shape
    _, keys, pos, has_gauss, gauss = ck.random_state
    problem = None
    if (len(shape) != 3 or shape[0] < 1 or ck.log_prob.shape != shape[:2] or ck.accepted.shape != (shape[1],)
            or keys.shape != (624,)):
        problem = f"chain {shape}, log_prob {ck.log_prob.shape}, accepted {ck.accepted.shape}"
    elif not np.all(np.isfinite(ck.chain)) or not np.all(np.isfinite(ck.log_prob)):
        problem = "draws or log-probabilities that are not finite numbers"
    elif not np.all((ck.accepted >= 0) & (ck.accepted <= shape[0])):
        problem = f"accepted-proposal counts outside [0, {shape[0]}]"
    elif (not (np.any(keys[1:]) or keys[0] & 0x80000000)  # MT19937 uses only the top bit of the first word
          or not 0 <= pos <= 624 or has_gauss not in (0, 1) or not math.isfinite(gauss)):
        problem = "a random-generator state numpy cannot continue from"
    else:
        problem = _check_moves(ck)
    if problem is not None:
        raise ResultsError(f"damaged checkpoint ({problem}); pass --force to start again", where)
