"""The report's progress line, as the study's jobs show theirs (studies/runner/src/progress_log.cpp):
on a terminal one live line redrawn in place (a bar, done/total, the rate, the time left, what
was last done), cleared at the end; on a pipe or file a line at each quarter; nothing when quiet.
Written to stderr; stdout keeps the one line make_report.py prints (index.html's path)."""

import sys
import time

BAR_WIDTH = 28  # as the jobs' bar (progress_log.cpp, DrawLocked)


class Progress:
    def __init__(self, total, unit="steps", stream=None, bar=None, quiet=False, clock=None):
        self.stream = sys.stderr if stream is None else stream
        self.bar = self.stream.isatty() if bar is None else bar
        self.total, self.unit, self.quiet = max(0, total), unit, quiet
        self.clock = clock or time.monotonic
        self.start = self.clock()
        self.done, self.quarter, self.current = 0, 0, ""

    def rate(self, elapsed):
        if elapsed <= 0 or self.done == 0:
            return f"-- {self.unit}/min"
        return f"{60.0 * self.done / elapsed:.1f} {self.unit}/min"

    def time_left(self, elapsed):
        f = self.done / self.total if self.total else 0.0
        if not (0.02 < f < 1):
            return "--:--"
        s = int(elapsed * (1 - f) / f)
        return f"{s // 60}:{s % 60:02d}"

    def step(self, current=""):
        """One more step done; `current`: what it was."""
        self.done = min(self.total, self.done + 1)
        if current:
            self.current = current
        if self.quiet:
            return
        elapsed = self.clock() - self.start
        if self.bar:
            f = self.done / self.total if self.total else 0.0
            filled = int(round(f * BAR_WIDTH))
            cur = self.current if len(self.current) <= 40 else self.current[:37] + "..."
            self.stream.write(f"\r\033[K[{'#' * filled}{'-' * (BAR_WIDTH - filled)}] "
                              f"{self.done}/{self.total}  {self.rate(elapsed)}  "
                              f"{self.time_left(elapsed)} left  {cur}")
            self.stream.flush()
            return
        quarter = 4 * self.done // self.total if self.total else 0
        if quarter > self.quarter and self.done < self.total:
            self.quarter = quarter
            self.stream.write(f"report: {self.done}/{self.total} {self.unit} "
                              f"({100 * self.done // self.total}%), {self.rate(elapsed)}, "
                              f"{self.time_left(elapsed)} left\n")
            self.stream.flush()

    def end(self):
        """Clears the live line (a terminal); a pipe's lines stay."""
        if self.bar and not self.quiet:
            self.stream.write("\r\033[K")
            self.stream.flush()
