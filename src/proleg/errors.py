"""Errors raised by proleg and the solver status codes returned from inside ``jit``.

Everything a user can get wrong is caught in plain Python at build or assembly time and raised
as a :class:`ModelError` that names the element, what was expected and how to fix it. Inside
compiled code a solver cannot raise; it returns an integer status (:class:`Status`) with the
time and the worst-offending element, and :func:`proleg.simulate` turns that into a
:class:`SolverError` (or a result whose ``status`` says what happened, with ``throw=False``).
Legal but suspicious inputs give a :class:`ProlegWarning`; Ctrl-C during a run raises
:class:`Interrupted` carrying what was computed. The README's "Errors and warnings" section
lists when each is raised, with an example message.
"""

from __future__ import annotations

import enum


class ModelError(ValueError):
    """A model, element or input file is inconsistent. The message says where and how to fix it."""


class DataError(ValueError):
    """A measurement file or array is unusable (missing column, NaN, unsorted time, ...)."""


class ConvergenceError(RuntimeError):
    """A static or initial-condition solve did not converge."""


class SolverError(RuntimeError):
    """A time integration stopped early. ``result`` holds everything computed before the stop."""

    def __init__(self, message: str, result=None):
        super().__init__(message)
        self.result = result


class ProlegWarning(UserWarning):
    """A legal but suspicious input (a negative gain, a stiffness the step cannot follow, an output
    name that matches nothing, ...). One line naming the element and the number; filter with
    ``warnings.simplefilter("error", proleg.ProlegWarning)`` to make them errors."""


class Interrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C (SIGINT). ``result`` holds everything computed up to the last
    finished chunk (a :class:`~proleg.analyses.result.Result`, or a sweep's finished batches);
    being a ``KeyboardInterrupt``, it still stops a script that does not catch it."""

    def __init__(self, message: str, result=None):
        super().__init__(message)
        self.result = result


class Status(enum.IntEnum):
    """Integer status codes returned by compiled solvers."""

    SUCCESS = 0
    NEWTON_FAILED = 1  # Newton did not converge and the step could not be reduced further
    STEP_TOO_SMALL = 2  # the error control asked for a step below ``dt_min``
    MAX_STEPS = 3  # the step budget of one call was exhausted
    NONFINITE = 4  # a NaN or inf appeared in the state
    INTERRUPTED = 5  # stopped by the user (Ctrl-C); set in Python, never by compiled code

    def describe(self) -> str:
        return {
            Status.SUCCESS: "success",
            Status.NEWTON_FAILED: "Newton iteration did not converge even at the minimum step",
            Status.STEP_TOO_SMALL: "the error control asked for a step below dt_min",
            Status.MAX_STEPS: "the maximum number of steps was reached",
            Status.NONFINITE: "a NaN or inf appeared in the state",
            Status.INTERRUPTED: "interrupted by the user (Ctrl-C)",
        }[self]
