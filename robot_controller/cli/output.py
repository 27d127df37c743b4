"""What the verbs write and show: the output directory (never overwriting results), the end of a verb (its
verdict and a dozen figures), the table of every figure, and a long verb's progress (a rich bar on a terminal,
else a line per step: ``[bench] 3/9 ...``)."""

from __future__ import annotations

import os
import shlex
import sys
from collections.abc import Callable
from pathlib import Path
from types import TracebackType

from robot_controller.cli.args import UsageError
from robot_controller.core.errors import ConfigError

# What marks a directory as holding results already.
RESULT_FILES = ("params.yaml", "bag", "metrics.json", "bench.json", "compare.json", "faults.json", "report.md")


def output_dir(out: Path | None, default: Path) -> Path:
    """Where a verb writes: an ``--out`` that holds results is refused, a used default becomes ``runs/faults-2``."""
    chosen = out if out is not None else default
    if chosen.exists() and not chosen.is_dir():
        raise UsageError(f"--out {chosen}: exists and is not a directory")
    if chosen.is_dir() and any((chosen / name).exists() for name in RESULT_FILES):
        if out is not None:
            raise UsageError(f"--out {chosen}: holds an earlier run; choose another directory (nothing was changed)")
        n = 2
        while (chosen.parent / f"{chosen.name}-{n}").exists():
            n += 1
        chosen = chosen.parent / f"{chosen.name}-{n}"
        print(f"robot-controller: {default} holds an earlier run: writing to {chosen}", file=sys.stderr)
    try:
        chosen.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out {chosen}: cannot create it ({exc.strerror})") from None
    if not os.access(chosen, os.W_OK | os.X_OK):
        raise UsageError(f"--out {chosen}: not writable")
    return chosen


def say_arm(robot: str) -> None:
    """What loading ``robot``'s description changed (fingers held still, meshes dropped), if anything."""
    from robot_controller import robots
    from robot_controller.runner import launcher

    if note := robots.robot(robot).note:
        launcher.say(note)


def typed_command(argv: list[str] | None = None) -> str:
    """The command as the user typed it, for a run's ``summary.md``."""
    argv = sys.argv if argv is None else argv
    program = Path(argv[0]).name if argv else "robot-controller"
    if program == "__main__.py":  # python -m robot_controller.cli
        program = "python -m robot_controller.cli"
    return " ".join([program, *(shlex.quote(arg) for arg in argv[1:])])


def print_summary(verdict_line: str | None, rows: list[tuple[str, str]]) -> None:
    """The end of a verb (:func:`robot_controller.scoring.summary.lines`), its verdict green ``ok`` or red
    ``FAILED: why``."""
    from rich.console import Console
    from rich.text import Text

    from robot_controller.scoring import summary

    console = Console(highlight=False, soft_wrap=True)
    for line in summary.lines(verdict_line, rows):
        style = ("bold green" if line == "ok" else "bold red") if verdict_line and line == verdict_line else None
        console.print(Text(line, style=style))


#: The figures a run's table shows first, in this order (``_m``, ``_n``: a prismatic joint's, if the arm has one).
HEADLINE = tuple(
    "tracking_rms_rad tracking_max_rad tracking_rms_m tracking_max_m measured_rms_rad control_rate_hz jitter_p99_ms "
    "missed_cycles latency_p50_ms latency_p99_ms peak_torque_nm peak_force_n duration_s real_time_factor".split()
)


def print_table(values: dict, title: str, headline: tuple[str, ...] = HEADLINE) -> None:
    """Every figure of ``values`` (``score DIR --all``): the headline first, then the rest by name."""
    from rich.console import Console
    from rich.table import Table

    from robot_controller.scoring.report import joint_table

    table = Table(title=title)
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key in headline + tuple(sorted(k for k in values if k not in headline)):
        if key in values and not isinstance(values[key], list):  # the per-joint lists: in their own table
            value = values[key]
            table.add_row(key, f"{value:.6g}" if isinstance(value, float) else str(value))
    Console().print(table)
    joints = joint_table(values)
    if joints is not None:
        Console().print(joints)


def run_experiment(
    verb: str,
    steps: int,
    body: Callable[[StepProgress], object],
    report: Path,
    hint: str | Callable[[], str | None] | None = None,
    show: Callable[[], None] | None = None,
) -> int:
    """``body(progress)`` with a progress line, then the report it wrote (or ``show()``) and a ``hint`` on using it
    (a callable: asked once the body has run).
    An experiment that fails is one line, exit 1; Ctrl-C ends it with 130."""
    try:
        with StepProgress(verb, steps) as progress:
            body(progress)
    except ConfigError:
        raise  # a user's mistake: exit 2
    except (RuntimeError, ValueError, FileExistsError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"robot-controller: {verb} interrupted", file=sys.stderr)
        return 130
    if show is not None:
        show()
    else:
        print(report.read_text())
    said = hint() if callable(hint) else hint  # (a hint may depend on what the experiment found)
    if said is not None:
        print(f"robot-controller: {said}")
    return 0


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

    def more(self, steps: int) -> None:
        """``steps`` more than were said (a pass repeated)."""
        self.total += steps

    def __call__(self, text: str) -> None:
        """A new step starts: the previous one is done (past the total said, the total grows: a step repeated)."""
        self.total = max(self.total, self.done + 1)
        if self._bar is not None:
            self._bar.update(self._task, total=self.total, completed=self.done, description=text)
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
