"""Progress of a long verb (compare, bench, faults, exercises): a rich progress
bar on a terminal, above which the runs' own output scrolls; on a pipe or in
CI, one plain line per step (``[bench] 3/9 wall clock 1 kHz, ...``)."""

from __future__ import annotations

import sys
from types import TracebackType


class StepProgress:
    """``with StepProgress("bench", total=9) as progress: progress("what starts now")``."""

    def __init__(self, verb: str, total: int) -> None:
        self.verb, self.total, self.done = verb, total, 0
        self._bar = None

    def __enter__(self) -> StepProgress:
        if sys.stdout.isatty():
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self._bar = Progress(
                TextColumn(f"[bold]{self.verb}[/bold]"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
                TextColumn("{task.description}"),
                redirect_stdout=True,
            )
            self._bar.__enter__()
            self._task = self._bar.add_task("", total=self.total)
        return self

    def __call__(self, text: str) -> None:
        """A new step starts: the previous one is done."""
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done, description=text)
        else:
            print(f"[{self.verb}] {self.done + 1}/{self.total} {text}", flush=True)
        self.done += 1

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if self._bar is not None:
            if exc_type is None:
                self._bar.update(self._task, completed=self.total, description="done")
            self._bar.__exit__(exc_type, exc, tb)
