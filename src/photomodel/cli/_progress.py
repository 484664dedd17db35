"""Rich progress bars on stderr (searches, datasets), silent when stderr is not a terminal."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

if TYPE_CHECKING:
    from photomodel.search import Optimizer


@contextmanager
def search_progress(label: str, enabled: bool) -> Iterator[Callable[[Optimizer], None] | None]:
    """Yield a callback for ``locate(progress=...)`` that shows iterations and best fitness."""
    if not enabled:
        yield None
        return
    with Progress(TextColumn("{task.description}"), BarColumn(),
                  TextColumn("iteration {task.completed:.0f}  best {task.fields[best]:.1f}"),
                  TimeElapsedColumn(), console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(label, total=None, best=0.0)

        def update(opt: Optimizer) -> None:
            res = opt.result
            bar.update(task, completed=res.iterations, best=res.fitness)

        yield update


@contextmanager
def count_progress(label: str, enabled: bool) -> Iterator[Callable[[int, int, str], None] | None]:
    """Yield a ``progress(done, total, what)`` callback that draws a bar of finished items."""
    if not enabled:
        yield None
        return
    with Progress(TextColumn("{task.description}"), BarColumn(),
                  TextColumn("{task.completed:.0f}/{task.total:.0f}  {task.fields[what]}"),
                  TimeElapsedColumn(), console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(label, total=None, what="")

        def update(done: int, total: int, what: str) -> None:
            bar.update(task, completed=done, total=total, what=what)

        yield update
