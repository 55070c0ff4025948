"""The progress bar of a simulation run (``simulate(..., progress=True)``).

The first chunk of a run includes its compilation, which can take most of a minute for a large
model on a small machine; a bar that sat at "t = 0.0000 s" through it looked hung. Until the
first chunk returns the bar reads ``<model> compiling…`` with the elapsed time ticking; then
``<model> t = 0.1234 s`` and the fraction of [t0, t_end] done.

The model name is printed as written (no rich markup: a name like ``leg[2]`` stays whole).
"""

from __future__ import annotations

from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

COMPILING = "compiling…"


class RunProgress:
    """A transient rich progress bar over simulated time [s].

    ``RunProgress(name, t0, t_end).start()``, then ``update(t)`` after each chunk, ``stop()`` at
    the end (also on an error; ``with RunProgress(...) as bar:`` does both). Before the first
    ``update`` the bar says :data:`COMPILING`. ``console``: a rich Console (default: stderr).
    """

    def __init__(self, name: str, t0: float, t_end: float, *, console=None):
        self.t0 = float(t0)
        self.compiling = True
        self.progress = Progress(
            TextColumn(f"[bold]{escape(str(name))}[/]"),
            TextColumn("{task.fields[state]}"),
            BarColumn(),
            TimeElapsedColumn(),
            transient=True,
            console=console,
        )
        self.task = self.progress.add_task("sim", total=max(float(t_end) - self.t0, 0.0), state=COMPILING)

    def start(self) -> RunProgress:
        self.progress.start()
        return self

    def update(self, t: float) -> None:
        """Simulated time ``t`` [s] reached: the label turns from compiling to ``t = ... s``."""
        self.compiling = False
        self.progress.update(self.task, completed=float(t) - self.t0, state=f"t = {float(t):.4f} s")

    def stop(self) -> None:
        self.progress.stop()

    def __enter__(self) -> RunProgress:
        return self.start()

    def __exit__(self, *exc) -> bool:
        self.stop()
        return False
