"""Termination signals end a command like Ctrl-C does, and short final writes are not cut.

SIGTERM (``kill``, a batch system's time limit), SIGHUP (the terminal closed, an ssh session
dropped) and SIGQUIT (Ctrl-\\) would otherwise end the process on the spot: a sampler would
lose the steps since its last save without a word, a batch would end without its summary.
While a command runs they raise :class:`KeyboardInterrupt` instead, so every command's
Ctrl-C path applies to them: temporary files are removed, a sampler saves its checkpoint (it
defers them to the end of the step under way, see :mod:`escfit.inference.mcmc`), and the
command says what was kept and exits with status 130.

:func:`deferred_interrupts` holds Ctrl-C and those signals back during a short piece of work
that should not be cut (the summary of a batch whose units are all fitted) and raises
:class:`KeyboardInterrupt` once it is done.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Iterator

__all__ = ["TERMINATING", "interrupting_signals", "deferred_interrupts"]

TERMINATING = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP", "SIGQUIT") if hasattr(signal, name))


def _interrupt(signum, frame):  # noqa: ARG001
    raise KeyboardInterrupt(signal.Signals(signum).name)


@contextlib.contextmanager
def _handled(signals: tuple, handler) -> Iterator[None]:
    """``handler`` for each of ``signals`` whose disposition is not "ignore", the previous
    handlers put back on leaving."""
    previous = {}
    try:
        for sig in signals:
            old = signal.getsignal(sig)
            if old is signal.SIG_IGN:
                continue
            previous[sig] = old
            signal.signal(sig, handler)
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)


@contextlib.contextmanager
def interrupting_signals() -> Iterator[None]:
    """While active (main thread only), SIGTERM, SIGHUP and SIGQUIT raise :class:`KeyboardInterrupt`.

    A signal whose disposition is "ignore" (``nohup`` sets SIGHUP so) stays ignored.  The
    previous handlers are put back on leaving.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    with _handled(TERMINATING, _interrupt):
        yield


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """While active (main thread only), Ctrl-C and the terminating signals are remembered, not
    acted on; on leaving, :class:`KeyboardInterrupt` is raised if one came.  A second Ctrl-C
    interrupts at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []

    def remember(signum, frame):  # noqa: ARG001
        if came and signum == signal.SIGINT:
            raise KeyboardInterrupt(signal.Signals(signum).name)
        came.append(signum)

    with _handled((signal.SIGINT, *TERMINATING), remember):
        yield
    if came:
        raise KeyboardInterrupt(signal.Signals(came[0]).name)
