"""Ctrl-C that is never lost: a run's loop asks for it at the points where it can stop cleanly.

Python's default SIGINT handler raises ``KeyboardInterrupt`` in whatever Python code the main
thread runs next. When that code is a garbage-collector callback (JAX registers one,
``_xla_gc_callback``, and it runs at any allocation, e.g. while a chunk's arrays are
concatenated), the interpreter prints "Exception ignored in: ..." and drops the exception: the
Ctrl-C is gone, and a long ``simulate`` goes on to its end (seen in
tests/test_issue22_interrupt.py: 120 s after SIGINT the child was still integrating). The same
handler can also raise half-way through writing a chunk to a store.

Inside :func:`deferred`, SIGINT only records itself; the loop calls :meth:`Pending.check` where
it can stop (after a chunk is recorded and written), which raises ``KeyboardInterrupt`` there.
A second Ctrl-C before that check raises at once, as Python's handler would (a user who presses
it twice wants out now), and stays recorded: if that exception is dropped too, ``check`` raises.
Outside the main thread, or where the program installed its own SIGINT handler, nothing is changed and ``check`` never raises: the program's handler decides.
"""

from __future__ import annotations

import contextlib
import signal
import threading

_state = {"hits": 0}  # Ctrl-Cs recorded and not yet acted on (one record: nested uses share it)


def _handler(signum, frame):
    _state["hits"] += 1
    if _state["hits"] > 1:  # the second Ctrl-C: at once (and still recorded, in case this one is lost too)
        _state["hits"] = 1
        raise KeyboardInterrupt


class Pending:
    """The handle :func:`deferred` yields."""

    def __init__(self, active: bool):
        self.active = active

    @property
    def requested(self) -> bool:
        """Whether a Ctrl-C arrived and was not yet acted on."""
        return self.active and _state["hits"] > 0

    def check(self) -> None:
        """Raise ``KeyboardInterrupt`` if a Ctrl-C arrived since the last check (and consume it)."""
        if self.requested:
            _state["hits"] = 0
            raise KeyboardInterrupt


@contextlib.contextmanager
def deferred():
    """Within: SIGINT is recorded instead of raised (the module docstring says why); nested uses
    share the outermost one's record. An interrupt still pending when the outermost use ends is
    delivered then, as ``KeyboardInterrupt`` (the program asked to stop; nothing is dropped)."""
    if threading.current_thread() is not threading.main_thread():
        yield Pending(False)
        return
    current = signal.getsignal(signal.SIGINT)
    if current is _handler:  # nested: the outer use restores and delivers
        yield Pending(True)
        return
    if current is not signal.default_int_handler:  # the program's own handler decides
        yield Pending(False)
        return
    _state["hits"] = 0
    signal.signal(signal.SIGINT, _handler)
    try:
        yield Pending(True)
    finally:
        signal.signal(signal.SIGINT, current)
        pending, _state["hits"] = _state["hits"] > 0, 0
    if pending:
        raise KeyboardInterrupt
