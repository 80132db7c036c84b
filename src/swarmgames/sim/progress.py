"""A transient progress bar on the terminal (rich), or nothing."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["ProgressBar"]


class ProgressBar:
    """Context manager yielding ``update(done, total=None)``, or ``None`` when disabled.

    Parameters
    ----------
    description : str
        Shown before the bar.
    enabled : bool
        False: nothing is shown and the context yields ``None``.
    total : float, optional
        Work to do, if known now (``update`` may set or change it).

    Examples
    --------
    >>> with ProgressBar("stages", enabled=False) as tick:
    ...     tick is None
    True
    """

    def __init__(self, description: str, enabled: bool, total: float | None = None) -> None:
        self.description, self.enabled, self.total = description, enabled, total
        self.bar: Any = None

    def __enter__(self) -> Callable[..., None] | None:
        if not self.enabled:
            return None
        from rich.progress import BarColumn, Progress, TaskProgressColumn, TimeElapsedColumn

        self.bar = Progress(
            "[progress.description]{task.description}",
            BarColumn(),
            TaskProgressColumn(),
            TimeElapsedColumn(),
            transient=True,
        )
        self.bar.__enter__()
        task = self.bar.add_task(self.description, total=self.total)

        def update(done: float, total: float | None = None) -> None:
            if total is None:
                self.bar.update(task, completed=done)
            else:
                self.bar.update(task, completed=done, total=total)

        return update

    def __exit__(self, *exc: Any) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)
