"""What the ``proleg`` commands print, and how an error ends a command.

Text is printed as it is written: rich's markup would read any lowercase ``[...]`` as a style
tag and drop it, so ``'time [s]'`` printed as ``'time '`` and ``pip install 'proleg[urdf]'`` as
``pip install 'proleg'``. The consoles here interpret no markup; colour comes from ``style=``
arguments only. The Typer apps set ``rich_markup_mode=None`` for the same reason in ``--help``.

Every error a command meets ends it with one line ``error: <message>`` on stderr and exit code
2 (a bad model, file or value) or 1 (the solver stopped, or an unexpected failure), never a
traceback: :class:`ErrorsAsOneLine` catches what a command raises; a warning prints as one line
``warning: <message>``. Set ``PROLEG_TRACEBACK=1``
to get the traceback instead (for a bug report).
"""

from __future__ import annotations

import os

import importlib

import typer
from rich.console import Console
from rich.text import Text
from typer.core import TyperGroup

MARKUP = None  # Typer(rich_markup_mode=MARKUP): help text printed as written


def console(stderr: bool = False) -> Console:
    """A rich console that prints text literally (tables, results); stderr for messages."""
    return Console(stderr=stderr, markup=False, highlight=False, emoji=False)


def say(message: str, style: str | None = None) -> None:
    """One message on stderr, as written (``style`` a rich style such as ``"green"``)."""
    console(stderr=True).print(Text(str(message), style=style or ""), soft_wrap=True)


def error(message, code: int = 2):
    """Print ``error: message`` as one line on stderr and end the command with ``code``."""
    text = " ".join(str(message).split("\n")).strip()
    typer.echo(typer.style("error:", fg="red") + " " + text, err=True)
    raise typer.Exit(code)


def _code(exc: BaseException) -> int:
    from ..errors import ConvergenceError, SolverError

    return 1 if isinstance(exc, SolverError | ConvergenceError) or not isinstance(exc, ValueError | TypeError | OSError) else 2


def _pass_through() -> tuple:
    """click's exit, abort and usage-error classes: typer >= 0.2x vendors click as typer._click,
    older typer uses click itself (both looked up)."""
    kinds = [typer.Exit, typer.Abort]
    for name in ("typer._click.exceptions", "click.exceptions"):
        try:
            mod = importlib.import_module(name)
        except ImportError:
            continue
        kinds += [getattr(mod, n, None) for n in ("ClickException", "Exit", "Abort")]
    return tuple(k for k in kinds if isinstance(k, type))


_PASS_THROUGH = _pass_through()


class ErrorsAsOneLine(TyperGroup):
    """A Typer group whose commands' exceptions end as one ``error:`` line (module docstring).

    click's own exits and usage errors pass through (click prints those); so does
    KeyboardInterrupt. proleg's errors (ModelError, DataError: exit 2; SolverError,
    ConvergenceError: exit 1) print their message; OSError its message (a file the user named);
    anything else its type too, as it is a bug to report."""

    def invoke(self, ctx):
        import warnings

        fmt = warnings.formatwarning
        warnings.formatwarning = _warning_line
        try:
            return super().invoke(ctx)
        except _PASS_THROUGH:
            raise
        except Exception as exc:
            if os.environ.get("PROLEG_TRACEBACK", "0") not in ("", "0"):
                raise
            from .. import errors

            known = tuple(getattr(errors, n) for n in ("ModelError", "DataError", "SolverError", "ConvergenceError", "Interrupted") if hasattr(errors, n))
            if isinstance(exc, known) or isinstance(exc, OSError):
                msg = str(exc) or type(exc).__name__
            else:
                msg = (f"{type(exc).__name__}: {exc} (an unexpected failure inside proleg: run again with "
                       "PROLEG_TRACEBACK=1 for the traceback, and please report it)")
            error(msg, _code(exc))
        finally:
            warnings.formatwarning = fmt


def _warning_line(message, category, filename, lineno, line=None):
    """A warning met by a command, as one line: ``warning: <message>`` (no source location:
    the user did not write the line that warns)."""
    return "warning: " + " ".join(str(message).split("\n")).strip() + "\n"
