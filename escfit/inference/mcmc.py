"""Posterior sampling with emcee for every model family, checkpointed in chunks and resumable.

Walkers start in a small ball around the least-squares solution; each walker is one ArviZ
``chain``.  A walker position whose forward solve fails has log-probability ``-inf`` (the
reason is counted in ``problem.failures``), which emcee simply rejects.

The run length is fixed (``steps = N``) or set by convergence (``steps = "auto"``: sample
until the criteria of :mod:`escfit.inference.convergence` hold, up to a cap).  The draws are
kept in memory and saved to the checkpoint (:mod:`escfit.inference.checkpoint`) every
``checkpoint_every`` seconds (the interval grows if saving would take more than a twentieth
of the time) and when the run is interrupted (Ctrl-C, SIGTERM, SIGHUP, SIGQUIT), so a resumed run draws
exactly what the uninterrupted one would have.

A problem that declares sampler coordinates (:mod:`escfit.inference.space`) is sampled in
them: the checkpoint holds the sampler's own draws (they round-trip exactly), and everything
else (convergence checks, the draws and log posteriors returned) is in the problem's
parameters.
"""

from __future__ import annotations

import math
import signal
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..core.errors import FitError, ResultsError
from ..core.limits import check_sampler_size
from ..likelihood.problem import Problem
from .checkpoint import Checkpoint, check_identity, load_checkpoint, run_identity, save_checkpoint
from .convergence import BURN_FAR, BURN_FRACTION, RHAT_MAX, Assessment, assess, autocorr_time, default_burn
from .emcee_import import emcee
from .lsq import LeastSquaresResult
from .ensemble import ArraySampler
from .moves import de_t_moves
from .space import IDENTITY, SamplerSpace, sampler_space

__all__ = ["McmcResult", "run_emcee", "resumable"]


@dataclass
class McmcResult:
    """Draws after burn-in and the run's diagnostics.

    Attributes
    ----------
    chain : ndarray, shape (walkers, draws, ndim)
    log_prob : ndarray, shape (walkers, draws)
    acceptance : ndarray, shape (walkers,)
    tau : ndarray, shape (ndim,)
        Integrated autocorrelation time per parameter (steps), from the whole run.
    steps, burn, walkers, seed : int
    tau_reliable : bool
        Whether the run is longer than 50 autocorrelation times (emcee's criterion).
    auto : bool
        Whether the run length was set by convergence (``steps = "auto"``).
    converged : bool or None
        With ``auto``: whether the criteria were met before the cap.
    verdict : str
        With ``auto``: the convergence figures at the stop, in one line.
    timings : dict
        Seconds spent sampling and saving checkpoints.
    figures : tuple of ndarray or None
        Split R-hat, bulk ESS and tail ESS of the kept draws (per parameter) when the automatic
        stop already computed them on exactly these draws; None otherwise.
    """

    names: list[str]
    chain: np.ndarray
    log_prob: np.ndarray
    acceptance: np.ndarray
    tau: np.ndarray
    steps: int
    burn: int
    walkers: int
    seed: int
    tau_reliable: bool
    resumed: bool = False
    failures: dict = field(default_factory=dict)
    moves: str = "stretch"
    auto: bool = False
    converged: bool | None = None
    verdict: str = ""
    timings: dict = field(default_factory=dict)
    figures: tuple | None = None


MOVES = {
    "stretch": lambda: None,
    # differential evolution alone: emcee 3.1.6's snooker move scales its step by sqrt(|s - z|)
    # instead of projecting on the unit vector, so its proposal is not symmetric and it biases
    # the posterior (30 % too narrow alone, 8 % in the usual 80/20 mix, on the friction rig)
    "de": lambda: emcee.moves.DEMove(),
    # independence proposals from a Student-t fitted to the other half-ensemble, mixed with
    # differential evolution (escfit.inference.moves): 3-5 times shorter autocorrelation times
    # on near-normal posteriors such as the quick start's
    "de-t": lambda: de_t_moves(),
}


def _start(problem: Problem, lsq: LeastSquaresResult | None, walkers: int, rng: np.random.Generator) -> np.ndarray:
    centre = problem.initial.copy()
    scale = np.abs(centre) * 1e-3 + 1e-8
    if lsq is not None:
        for i, n in enumerate(problem.names):
            if n in lsq.names:
                j = lsq.names.index(n)
                centre[i] = lsq.value[j]
                se = lsq.stderr[j]
                scale[i] = 0.1 * se if np.isfinite(se) and se > 0 else abs(centre[i]) * 1e-3 + 1e-8
            elif n == "observation.sigma" and np.isfinite(lsq.sigma_hat) and lsq.sigma_hat > 0:
                centre[i] = lsq.sigma_hat
                scale[i] = 0.05 * lsq.sigma_hat
            elif n in lsq.values and np.isfinite(lsq.values[n]):  # a noise parameter least squares held
                centre[i] = float(lsq.values[n])
                scale[i] = abs(centre[i]) * 1e-2 + 1e-8
    lo, hi = problem.bounds
    span = np.where(np.isfinite(hi - lo), hi - lo, np.inf)
    centre = np.clip(centre, lo + 1e-9 * np.minimum(span, 1.0), hi - 1e-9 * np.minimum(span, 1.0))
    out = np.empty((walkers, centre.size))
    for w in range(walkers):
        for _ in range(200):
            x = centre + scale * rng.standard_normal(centre.size)
            x = np.clip(x, lo, hi)
            if math.isfinite(problem.log_prob(x)):
                out[w] = x
                break
        else:
            raise FitError("could not place the walkers: the log posterior is -inf around the least-squares solution "
                           f"(reasons: {dict(problem.failures)})")
    return out


def resumable(problem: Problem, checkpoint: str | Path, *, walkers: int, moves: str, seed: int, target: int | None,
              provenance: Mapping[str, Any] | None = None, fit_options: Mapping[str, Any] | None = None) -> Checkpoint:
    """The checkpoint a resumed run continues, after checking that it belongs to this run.

    Checked: its shape and parameters, its moves, its identity (:func:`run_identity`: data,
    scene, options, walkers, seed), that a fixed-length run (``target`` steps) is not shorter
    than what it holds, that every draw of every step lies inside the bounds, and that the
    posterior gives the walker positions of :data:`CHECKED_STEPS` steps (the first and the last
    among them) the stored log-probabilities.  Cheap (five evaluations per walker), so
    :func:`escfit.fit` calls it before any other work too.

    Raises
    ------
    ResultsError
        Naming the checkpoint and the first thing that differs.
    """
    where = str(checkpoint)
    previous = load_checkpoint(checkpoint, walkers, list(problem.names))
    space = sampler_space(problem)
    if previous.coordinates != space.name:
        raise ResultsError(f"the checkpoint's draws are in sampler coordinates {previous.coordinates!r}, this run "
                           f"samples in {space.name!r}; pass --force to start again", where)
    if previous.moves != moves:
        raise ResultsError(f"the checkpoint's run used moves {previous.moves!r}, this one asks for {moves!r}; "
                           "resume with the same moves, or pass --force to start again", where)
    ident = run_identity(provenance, fit_options, walkers=walkers, moves=moves, seed=seed, names=list(problem.names))
    check_identity(previous, ident, where)
    if target is not None and previous.steps > target:
        raise ResultsError(f"the checkpoint already holds {previous.steps} steps, more than the {target} asked "
                           f"for; resume with --steps {previous.steps} or more, or pass --force to start again", where)
    _check_support(problem, previous, where, space)
    return previous


# Steps of a checkpoint whose log-probabilities are recomputed before resuming (first and last among them)
CHECKED_STEPS = 5


def _check_support(problem: Problem, ck: Checkpoint, where: str, space: SamplerSpace = IDENTITY) -> None:
    """Refuse a checkpoint whose draws this posterior cannot have given: any draw (of any step)
    outside the bounds, or stored log-probabilities that it does not give at the walker
    positions of :data:`CHECKED_STEPS` steps spread over the run, the first and the last among
    them (continuing would reuse them, and the kept draws would not be this posterior's)."""
    _check_bounds(problem, ck, where, space)
    steps = np.unique(np.linspace(0, ck.steps - 1, min(ck.steps, CHECKED_STEPS)).round().astype(int))
    for t in steps[::-1]:  # the last step first: the one a resumed run continues from
        now = space.log_prob_many(ck.chain[t]) if space.transformed else np.array(
            [problem.log_prob(x) for x in ck.chain[t]])
        tol = 1e-8 * (1.0 + np.abs(ck.log_prob[t]))  # rounding of another library version, not another posterior
        bad = ~(np.abs(now - ck.log_prob[t]) <= tol)
        if np.any(bad):
            w = int(np.argmax(bad))
            raise ResultsError(f"the checkpoint belongs to another posterior: walker {w}'s stored log-probability "
                               f"at step {t + 1} of {ck.steps} is {ck.log_prob[t][w]:.10g}, {now[w]:.10g} now; "
                               "pass --force to start again", where)


def _check_bounds(problem: Problem, ck: Checkpoint, where: str, space: SamplerSpace) -> None:
    """Refuse a checkpoint with a draw, at any step, outside the bounds (or not finite in the
    problem's parameters), naming the first step and parameter."""
    lo, hi = problem.bounds
    x = space.to_problem(ck.chain.reshape(-1, ck.chain.shape[-1])).reshape(ck.chain.shape)
    outside = ~np.isfinite(x) | (x < lo) | (x > hi)
    if np.any(outside):
        t, _, i = (int(k[0]) for k in np.nonzero(outside))
        raise ResultsError(f"damaged checkpoint: step {t + 1} of {ck.steps} stands outside the bounds of "
                           f"{problem.names[i]} ([{lo[i]:g}, {hi[i]:g}]); pass --force to start again", where)


AUTO_MIN_STEPS = 400  # first look at convergence
AUTO_GROWTH = 1.05  # later looks: each after the run has grown by a twentieth (a look mostly costs one R-hat)


def run_emcee(problem: Problem, lsq: LeastSquaresResult | None = None, *, walkers: int = 32,
              steps: int | str = 2000, burn: int | None = None, seed: int = 0, checkpoint: str | Path | None = None,
              resume: bool = False, progress: bool = False, vectorize: bool | None = None, moves: str = "stretch",
              max_steps: int = 20000, checkpoint_every: float = 10.0,
              provenance: Mapping[str, Any] | None = None, fit_options: Mapping[str, Any] | None = None
              ) -> McmcResult:
    """Sample the posterior.

    Parameters
    ----------
    walkers
        Ensemble size (at least twice the number of free parameters).
    steps
        Total steps, or ``"auto"``: sample until every parameter has split R-hat <= 1.01, bulk
        and tail ESS >= 400 and the run is longer than 50 autocorrelation times
        (:mod:`escfit.inference.convergence`), looking first after 400 steps and then each time
        the run has grown by a twentieth, up to ``max_steps``.
    burn
        Steps discarded at the start (default: the first quarter of the run when the walkers start
        at ``lsq``'s optimum, else the first half; :func:`~escfit.inference.convergence.default_burn`).
    seed
        Seeds the start ball and emcee's own generator.
    checkpoint
        HDF5 file the draws are saved to while sampling (:mod:`escfit.inference.checkpoint`);
        the run can be resumed from it after an interruption.
    resume
        Continue the run stored in ``checkpoint`` (to ``steps`` in total, or until converged).
    progress
        Show a progress bar (tqdm).
    moves
        ``"stretch"`` (emcee's default affine-invariant stretch move), ``"de"`` (differential
        evolution), which mixes faster on posteriors with strongly coupled directions such as
        a noise scale and its correlation, and on one-parameter posteriors, or ``"de-t"``
        (:func:`~escfit.inference.moves.de_t_moves`: independence proposals from a Student-t
        fitted to the other half of the ensemble, 80 %, and differential evolution, 20 %),
        which on near-normal posteriors reaches the same convergence in 3-5 times fewer steps.
    vectorize
        Evaluate each half-ensemble of proposals in one call of
        :meth:`Problem.log_prob_many` (emcee's ``vectorize=True``).  Default: the problem's
        own declaration :attr:`Problem.vectorized` (a whole-array path that gives the same
        numbers as ``log_prob`` walker by walker, so the draws are identical too).  A problem
        with declared sampler coordinates (:mod:`escfit.inference.space`) is always evaluated
        through ``log_prob_many``.
    max_steps
        Cap of an ``"auto"`` run.
    checkpoint_every
        Seconds between checkpoint saves (at least; longer when a save is slow): a finite
        number >= 0.
    provenance, fit_options
        The problem's provenance (data SHA-256, scene text, solver, ...) and the options it
        was built with: with the sampler's settings they are the run's identity
        (:func:`~escfit.inference.checkpoint.run_identity`), recorded in the checkpoint; a
        resume whose identity differs is refused, naming the difference.
    """
    ndim = len(problem.names)
    auto = steps == "auto"
    target = int(max_steps) if auto else steps
    if isinstance(target, bool) or not isinstance(target, (int, np.integer)):
        raise FitError(f"steps must be a whole number or 'auto', got {steps!r}")
    if walkers < 2 * ndim:
        raise FitError(f"emcee needs at least {2 * ndim} walkers for {ndim} free parameters, got {walkers}")
    if target < 10:
        raise FitError(f"{'max_steps' if auto else 'steps'} must be at least 10, got {target}")
    check_sampler_size(walkers, int(target), ndim)
    if burn is not None and not 0 <= int(burn) < target:
        raise FitError(f"burn must lie in [0, {'max_steps' if auto else 'steps'}), got {burn}")
    if moves not in MOVES:
        raise FitError(f"moves must be one of {sorted(MOVES)}, got {moves!r}")
    if isinstance(checkpoint_every, bool) or not isinstance(checkpoint_every, (int, float)) or not (
            math.isfinite(checkpoint_every) and checkpoint_every >= 0):
        raise FitError(f"checkpoint_every must be a finite number of seconds >= 0, got {checkpoint_every!r}")
    previous = None
    if resume:
        if checkpoint is None:
            raise FitError("resume needs the checkpoint of the run to continue (give out or checkpoint)")
        previous = resumable(problem, checkpoint, walkers=walkers, moves=moves, seed=seed, target=None if auto else target,
                             provenance=provenance, fit_options=fit_options)
    ident = run_identity(provenance, fit_options, walkers=walkers, moves=moves, seed=seed, names=list(problem.names))
    space = sampler_space(problem)
    if space.transformed:  # the sampler's density, row-wise through the problem's log_prob_many
        vectorize, fn = True, space.log_prob_many
    else:
        if vectorize is None:
            vectorize = bool(getattr(problem, "vectorized", False))
        fn = problem.log_prob_many if vectorize else problem.log_prob
    sampler = ArraySampler(walkers, ndim, fn, vectorize=vectorize, moves=MOVES[moves]())
    run = _Run(problem, sampler, previous, checkpoint, seed, moves, checkpoint_every, ident, space)
    run.burn_fraction = BURN_FRACTION if lsq is not None else BURN_FAR  # walkers started at the optimum, or not
    if previous is None:
        sampler.random_state = np.random.RandomState(seed).get_state()
        start = space.to_sampler(_start(problem, lsq, walkers, np.random.default_rng(seed)))
        if not np.all(np.isfinite(start)):
            raise FitError(f"could not place the walkers in the sampler's coordinates {space.name}: the start lies "
                           "outside their domain")
        run.start(start)
    assessment = run.advance(target, auto, progress, burn)
    chain, lp = run.chain(), run.log_prob()
    total = chain.shape[0]
    # the stop's last assessment dropped the same burn-in when it was complete and of this run
    same = (assessment is not None and assessment.complete and assessment.steps == total
            and (burn is None or int(burn) <= total - 1))
    burn = default_burn(total, run.burn_fraction) if burn is None else min(int(burn), total - 1)
    tau = assessment.tau if assessment is not None and assessment.steps == total else autocorr_time(chain)
    kept = chain[burn:].transpose(1, 0, 2)
    return McmcResult(list(problem.names), kept, lp[burn:].T, run.accepted / max(total, 1), np.asarray(tau),
                      total, burn, walkers, seed, bool(np.all(total > 50 * np.asarray(tau))),
                      resumed=previous is not None, failures=dict(problem.failures), moves=moves, auto=auto,
                      converged=None if not auto else bool(assessment is not None and assessment.converged),
                      verdict="" if assessment is None else assessment.verdict(), timings=run.timings,
                      figures=(assessment.rhat, assessment.ess_bulk, assessment.ess_tail) if same else None)


class _Run:
    """The draws of one run in memory, advanced step by step and saved in chunks."""

    def __init__(self, problem: Problem, sampler: emcee.EnsembleSampler, previous: Checkpoint | None,
                 path: str | Path | None, seed: int, moves: str, every: float, identity: dict,
                 space: SamplerSpace = IDENTITY) -> None:
        self.problem, self.sampler, self.path, self.space = problem, sampler, path, space
        self.seed, self.moves, self.every, self.identity = seed, moves, float(every), identity
        self.parts: list[np.ndarray] = []
        self.lp_parts: list[np.ndarray] = []
        self.accepted = np.zeros(sampler.nwalkers, np.int64)
        self.state: emcee.State | None = None
        self.saved_steps = 0
        self.timings = {"sampling_s": 0.0, "checkpoint_s": 0.0, "checkpoint_saves": 0}
        self.burn_fraction = BURN_FRACTION  # of the run discarded when no burn-in is given
        if previous is not None:
            self.parts, self.lp_parts = [previous.chain], [previous.log_prob]
            self.accepted = previous.accepted.copy()
            self.state = emcee.State(previous.chain[-1], log_prob=previous.log_prob[-1],
                                     random_state=previous.random_state)
            self.saved_steps = previous.steps

    @property
    def steps(self) -> int:
        return int(sum(p.shape[0] for p in self.parts))

    def sampler_chain(self) -> np.ndarray:
        """The draws as the sampler holds them (its coordinates), shape (steps, walkers, ndim)."""
        return np.concatenate(self.parts) if self.parts else np.zeros((0, self.sampler.nwalkers, self.sampler.ndim))

    def sampler_log_prob(self) -> np.ndarray:
        """The sampler's log density of every draw, shape (steps, walkers)."""
        return np.concatenate(self.lp_parts) if self.lp_parts else np.zeros((0, self.sampler.nwalkers))

    def chain(self) -> np.ndarray:
        """The draws in the problem's parameters."""
        return self.space.to_problem(self.sampler_chain())

    def log_prob(self) -> np.ndarray:
        """The problem's log posterior of every draw."""
        if not self.space.transformed:
            return self.sampler_log_prob()
        return self.space.problem_log_prob(self.sampler_chain(), self.sampler_log_prob())

    def start(self, coords: np.ndarray) -> None:
        lp, _ = self.sampler.compute_log_prob(coords)
        self.state = emcee.State(coords, log_prob=lp, random_state=self.sampler.random_state)

    def advance(self, target: int, auto: bool, progress: bool, burn: int | None) -> Assessment | None:
        """Sample to ``target`` steps in all (or, with ``auto``, until converged); save on the way.

        Convergence is looked at on one fixed sequence of run lengths (:func:`look_points`), so
        a resumed run stops where the uninterrupted one would.  Ctrl-C, SIGTERM, SIGHUP and
        SIGQUIT only raise a flag while sampling; the step under way is finished, the steps done
        are saved and then :class:`KeyboardInterrupt` is raised (a second Ctrl-C interrupts at once).
        """
        assessment = None
        if auto and self.steps in look_points(self.steps):
            assessment = assess(self.chain(), burn, rhat_first=True, burn_fraction=self.burn_fraction)
            if assessment.converged:
                return assessment
        look = next_look(self.steps)
        bar = _bar(progress, self.steps, None if auto else target)
        buf, lp_buf = [], []
        last_save = time.monotonic()
        stop = _Interrupts()
        t0, saving0 = time.perf_counter(), self.timings["checkpoint_s"]
        try:
            with stop:
                gen = self.sampler.sample(self.state, iterations=None, store=False, skip_initial_state_check=True)
                while self.steps + len(buf) < target:
                    state = next(gen)
                    # one step, recorded in full before anything else can happen
                    coords, lp = state.coords.copy(), state.log_prob.copy()
                    moved = np.any(coords != self.state.coords, axis=1)
                    self.state = emcee.State(coords, log_prob=lp, random_state=state.random_state)
                    self.accepted += moved
                    buf.append(coords)
                    lp_buf.append(lp)
                    if bar is not None:
                        bar.update(1)
                    done = self.steps + len(buf)
                    if auto and done >= look:
                        self._flush(buf, lp_buf)
                        assessment = assess(self.chain(), burn, rhat_first=True, burn_fraction=self.burn_fraction,
                                            first=_failing(assessment))
                        if assessment.converged:
                            break
                        look = next_look(done)
                    if stop.raised:
                        raise KeyboardInterrupt
                    if self.path is not None and time.monotonic() - last_save >= self.every:
                        self._flush(buf, lp_buf)
                        self.save()
                        last_save = time.monotonic()
        except KeyboardInterrupt:
            self._flush(buf, lp_buf)  # the steps completed before the interrupt
            if self.path is not None and self.steps > self.saved_steps:
                self.save()
            raise
        finally:
            self.timings["sampling_s"] += time.perf_counter() - t0 - (self.timings["checkpoint_s"] - saving0)
            if bar is not None:
                bar.close()
        self._flush(buf, lp_buf)
        if self.path is not None and self.steps > self.saved_steps:
            self.save()  # an interrupt during the diagnostics or the writing keeps every draw
        if auto and (assessment is None or assessment.steps != self.steps or not assessment.complete):
            assessment = assess(self.chain(), burn, burn_fraction=self.burn_fraction)
        return assessment

    def _flush(self, buf: list, lp_buf: list) -> None:
        if buf:
            self.parts.append(np.array(buf))
            self.lp_parts.append(np.array(lp_buf))
            buf.clear()
            lp_buf.clear()

    def save(self) -> None:
        t0 = time.perf_counter()
        save_checkpoint(self.path, Checkpoint(self.sampler_chain(), self.sampler_log_prob(), self.accepted,
                                              self.state.random_state, list(self.problem.names), self.seed, self.moves,
                                              self.identity, coordinates=self.space.name))
        self.saved_steps = self.steps
        spent = time.perf_counter() - t0
        self.timings["checkpoint_s"] += spent
        self.timings["checkpoint_saves"] += 1
        self.every = max(self.every, 20.0 * spent)  # saving costs at most a twentieth of the run


def _failing(assessment: Assessment | None) -> int | None:
    """The parameter whose R-hat failed the last look (to be looked at first in the next), if any."""
    if assessment is None:
        return None
    failed = np.flatnonzero(np.isfinite(assessment.rhat) & ~(assessment.rhat <= RHAT_MAX))
    return int(failed[0]) if failed.size else None


def look_points(upto: int) -> list[int]:
    """Run lengths at which an ``"auto"`` run looks at convergence, up to ``upto``: 400, then each
    a twentieth longer than the one before (400, 420, 441, 463, ...).  A look that fails stops at
    the first parameter whose R-hat fails, looked at first the next time, so it mostly costs one
    parameter's R-hat."""
    out, n = [], AUTO_MIN_STEPS
    while n <= upto:
        out.append(n)
        n = max(n + 1, int(n * AUTO_GROWTH))
    return out


def next_look(done: int) -> int:
    """The first look point after ``done`` steps."""
    n = AUTO_MIN_STEPS
    while n <= done:
        n = max(n + 1, int(n * AUTO_GROWTH))
    return n


def _bar(progress: bool, done: int, total: int | None):
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, initial=done, unit="step", desc="emcee")


class _Interrupts:
    """While active (main thread only), Ctrl-C, SIGTERM, SIGHUP and SIGQUIT set :attr:`raised`
    instead of raising in the middle of a step; a second Ctrl-C raises :class:`KeyboardInterrupt`
    at once.  A signal set to be ignored (``nohup`` ignores SIGHUP) stays ignored."""

    SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT")
                    if hasattr(signal, name))

    def __init__(self) -> None:
        self.raised = False
        self._old: dict = {}

    def _handler(self, signum, frame):  # noqa: ARG002
        if self.raised and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.raised = True

    def __enter__(self) -> "_Interrupts":
        try:
            for sig in self.SIGNALS:
                if signal.getsignal(sig) is not signal.SIG_IGN:
                    self._old[sig] = signal.signal(sig, self._handler)
        except ValueError:  # not the main thread (a worker of a batch): leave signals alone
            self._restore()
        return self

    def __exit__(self, *exc) -> None:
        self._restore()

    def _restore(self) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)
        self._old.clear()
