"""Ending the command-line process without the interpreter's teardown.

Once a command has finished, tearing the interpreter down (destroying every module, numba's
compiled libraries and LLVM's state, the imported scientific stack) cost more than a second of
CPU of a least-squares fit that takes three.  :func:`finish` does what an orderly exit does for
the program's output and the libraries' clean-up (waits for non-daemon threads, flushes stdout
and stderr, runs the ``atexit`` handlers, which include ``weakref.finalize`` callbacks such as
temporary folders' removal and h5py's closing of files) and then ends the process at once.
escfit writes every output file whole before a command returns (:mod:`escfit.core.atomic`),
so nothing is left for a destructor to write.
"""

from __future__ import annotations

import atexit
import os
import sys
import threading
from typing import NoReturn

__all__ = ["exit_status", "finish", "run_and_exit"]


def exit_status(code) -> int:
    """The process exit status of ``SystemExit(code)``: ``None`` is 0; text is printed on stderr, status 1."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code & 0xFF
    try:
        print(code, file=sys.stderr)
    except (OSError, ValueError):
        pass
    return 1


def finish(status: int) -> NoReturn:
    """End the process with ``status`` after the orderly parts of an exit (see the module's notes).

    Under a profiler or a tracer (``python -m cProfile``, a debugger, coverage) the exit is the
    interpreter's own, so that they can write what they collected when the program ends.
    """
    if sys.getprofile() is not None or sys.gettrace() is not None:
        sys.exit(status)
    main = threading.main_thread()
    for thread in threading.enumerate():
        if thread is not main and not thread.daemon:
            thread.join()
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # the reader went away or the stream is closed: nothing to save
            pass
    atexit._run_exitfuncs()
    os._exit(status)


def run_and_exit(command, **kwargs) -> NoReturn:
    """Run a click ``command`` as a program (standalone) and :func:`finish` with its exit status."""
    try:
        command(**kwargs)
    except SystemExit as exc:
        finish(exit_status(exc.code))
    finish(0)
