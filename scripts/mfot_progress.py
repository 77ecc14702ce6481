"""Progress with an ETA for the long scripts (bench-baselines, particle-sweep, soak, bench-pcd-scenes,
bench-hosts), standard library plus what Debian has:

    with mfot_progress.Progress("particle-sweep", total=7, unit="runs") as bar:
        ...
        bar.advance(1, note="100 particles")      # a step done
        bar.update(123.0, note="4100 frames")     # or: how far, absolutely
    mfot_progress.write("[particle-sweep] ...")   # a log line, kept above a live bar

On a terminal (stderr is a tty) the bar is Debian's python3-rich if it imports, else python3-tqdm, else
plain lines. When stderr is not a terminal (CI, a log file, a pipe) there is no bar: plain lines only,
one per step done and at most one per `interval_s` for update(), without carriage returns or escape
codes. MFOT_PROGRESS=off shows nothing, MFOT_PROGRESS=lines always plain lines. Standard output is left
alone (what the scripts print there, a table or JSON, stays as it was) unless it is the same terminal.
"""

from __future__ import annotations

import atexit
import os
import sys
import time
from typing import Callable, List, Optional, TextIO

_active: List["Progress"] = []


def _is_tty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def choose_backend(stream: TextIO) -> str:
    """"off", "lines", "rich" or "tqdm" for this stream and $MFOT_PROGRESS."""
    mode = os.environ.get("MFOT_PROGRESS", "auto").lower()
    if mode in ("off", "0", "no", "none"):
        return "off"
    if mode == "lines" or not _is_tty(stream):
        return "lines"
    try:
        import rich.progress  # noqa: F401

        return "rich"
    except ImportError:
        pass
    try:
        import tqdm  # noqa: F401

        return "tqdm"
    except ImportError:
        return "lines"


def clock_text(seconds: Optional[float]) -> str:
    if seconds is None or seconds != seconds or seconds == float("inf"):
        return "?"
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}" if hours else f"{rest // 60}:{rest % 60:02d}"


def _number(value: float) -> str:
    return f"{int(round(value))}" if abs(value - round(value)) < 1e-9 else f"{value:.1f}"


class Progress:
    """One task's progress towards `total` (steps, seconds, frames: `unit`)."""

    def __init__(self, name: str, total: float, unit: str = "steps", stream: Optional[TextIO] = None,
                 interval_s: float = 30.0, backend: Optional[str] = None,
                 clock: Callable[[], float] = time.monotonic):
        self.name, self.total, self.unit = name, max(float(total), 0.0), unit
        self.stream = stream if stream is not None else sys.stderr
        self.interval_s, self.clock = interval_s, clock
        self.backend = backend or choose_backend(self.stream)
        self.completed = 0.0
        self.note = ""
        self.started = clock()
        self.last_line = None
        self.closed = False
        self._bar = None
        if self.backend == "rich":
            from rich.console import Console
            from rich.progress import (BarColumn, MofNCompleteColumn, Progress as RichProgress, TaskProgressColumn,
                                       TextColumn, TimeElapsedColumn, TimeRemainingColumn)

            self._bar = RichProgress(TextColumn(f"[bold]{name}[/]"), BarColumn(), MofNCompleteColumn(),
                                     TextColumn(unit), TaskProgressColumn(), TimeElapsedColumn(),
                                     TextColumn("ETA"), TimeRemainingColumn(),
                                     TextColumn("{task.fields[note]}", markup=False),
                                     console=Console(file=self.stream), redirect_stdout=_is_tty(sys.stdout),
                                     redirect_stderr=False)
            self._task = self._bar.add_task(name, total=self.total, note="")
            self._bar.start()
        elif self.backend == "tqdm":
            import tqdm

            total = int(self.total) if self.total == int(self.total) else self.total
            self._bar = tqdm.tqdm(total=total, desc=name, unit=f" {unit}", file=self.stream, dynamic_ncols=True,
                                  bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt}{unit} "
                                             "[{elapsed}, ETA {remaining}{postfix}]")
        _active.append(self)
        if self._bar is not None:
            atexit.register(self.close)  # a script that exits mid-way leaves the terminal as it was

    # -- progress ----------------------------------------------------------------------------

    def eta_s(self) -> Optional[float]:
        """Seconds left at the pace so far; None before any progress."""
        if self.completed <= 0 or self.total <= 0:
            return None
        elapsed = self.clock() - self.started
        return max(0.0, elapsed * (self.total - self.completed) / self.completed)

    def advance(self, amount: float = 1.0, note: str = "") -> None:
        """`amount` more done (a step finished): always shown."""
        self._set(self.completed + amount, note, step=True)

    def update(self, completed: float, note: str = "") -> None:
        """`completed` done so far (a running measure): plain lines at most every interval_s."""
        self._set(completed, note, step=False)

    def _set(self, completed: float, note: str, step: bool) -> None:
        if self.closed:
            return
        completed = min(max(float(completed), 0.0), self.total) if self.total else float(completed)
        delta = completed - self.completed
        self.completed, self.note = completed, note or self.note
        if self.backend == "rich":
            self._bar.update(self._task, completed=completed, note=self.note)
        elif self.backend == "tqdm":
            if delta:
                self._bar.update(int(delta) if delta == int(delta) else delta)
            if note:
                self._bar.set_postfix_str(note, refresh=True)
        elif self.backend == "lines":
            now = self.clock()
            due = self.last_line is None or now - self.last_line >= self.interval_s
            if step or due or (completed >= self.total and delta > 0):
                self._line(now)

    def line_text(self) -> str:
        elapsed = self.clock() - self.started
        share = f" ({100.0 * self.completed / self.total:.0f} %)" if self.total else ""
        text = (f"[{self.name}] {_number(self.completed)}/{_number(self.total)} {self.unit}{share}, "
                f"elapsed {clock_text(elapsed)}, ETA {clock_text(self.eta_s())}")
        return text + (f": {self.note}" if self.note else "")

    def _line(self, now: float) -> None:
        self.last_line = now
        print(self.line_text(), file=self.stream, flush=True)

    # -- output ------------------------------------------------------------------------------

    def write(self, line: str) -> None:
        """A log line for standard output that does not break the bar."""
        if self.backend == "rich" and _is_tty(sys.stdout):
            self._bar.console.print(line, markup=False, highlight=False, soft_wrap=True)
        elif self.backend == "tqdm" and _is_tty(sys.stdout):
            self._bar.write(line, file=sys.stdout)
        else:
            print(line, flush=True)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        if self in _active:
            _active.remove(self)
        if self.backend == "rich":
            self._bar.stop()
        elif self.backend == "tqdm":
            self._bar.close()
        elif self.backend == "lines" and self.last_line is not None:
            elapsed = self.clock() - self.started
            print(f"[{self.name}] {_number(self.completed)}/{_number(self.total)} {self.unit} in "
                  f"{clock_text(elapsed)}", file=self.stream, flush=True)

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def write(line: str) -> None:
    """Prints a log line to standard output, above the newest live bar if one is showing."""
    if _active:
        _active[-1].write(line)
    else:
        print(line, flush=True)
