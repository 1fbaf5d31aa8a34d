"""The messages of reading one `.mod` file, bounded whatever the file holds: every warning has a kind;
a kind seen up to SHOWN_EACH times is said each time, one seen more often is one warning naming how
many rows have it and the first few lines. The first MAX_ERRORS errors are shown, each at its cell,
and the rest counted in one last error."""

from __future__ import annotations

from dataclasses import dataclass, field

from mdl.diagnostics import Diagnostic

MAX_ERRORS = 100  # errors shown one by one; the rest are counted
SHOWN_LINES = 3  # lines a summary names
SHOWN_EACH = 3  # a warning of a kind seen this often or less is said each time


@dataclass
class _Seen:
    """Where something was seen: how many rows, the first few lines."""

    first: list[Diagnostic]  # the first SHOWN_EACH
    times: int = 0
    rows: int = 0
    lines: list[int] = field(default_factory=list)
    last_line: int | None = None

    def add(self, line: int | None) -> None:
        self.times += 1
        if self.rows and line == self.last_line:
            return  # the same row again (two cells of one row count once)
        self.rows += 1
        self.last_line = line
        if line is not None and len(self.lines) < SHOWN_LINES:
            self.lines.append(line)

    def where(self) -> str:
        more = ", ..." if self.rows > len(self.lines) else ""
        return f"line{'s' * (len(self.lines) > 1)} {', '.join(map(str, self.lines))}{more}"


class Reporter:
    """The diagnostics of one file: `error`, `warn` (with the kind of warning it is), `diagnostics()`."""

    def __init__(self, path: str):
        self.path = path
        self.errors: list[Diagnostic] = []
        self.more_errors: _Seen | None = None  # the errors past MAX_ERRORS
        self.kinds: dict[str, _Seen] = {}  # a kind of warning or note -> where it was seen

    @property
    def failed(self) -> bool:
        return bool(self.errors)

    def error(self, line: int | None, col: int | None, message: str, always: bool = False) -> None:
        """An error; `always`: shown even past MAX_ERRORS (why the reader stopped)."""
        diagnostic = Diagnostic(self.path, line, col, message)
        if always or len(self.errors) < MAX_ERRORS:
            self.errors.append(diagnostic)
            return
        if self.more_errors is None:
            self.more_errors = _Seen([diagnostic])
        self.more_errors.add(line)

    def warn(self, line: int | None, col: int | None, message: str, kind: str, severity: str = "warning") -> None:
        """A warning (or note) of `kind`: a fixed text that says what happened, without the cell's
        words (`kind` on N rows reads as a sentence)."""
        seen = self.kinds.setdefault(kind, _Seen([]))
        if len(seen.first) < SHOWN_EACH:
            seen.first.append(Diagnostic(self.path, line, col, message, severity))
        seen.add(line)

    def diagnostics(self) -> list[Diagnostic]:
        """Every message, in file order: a kind seen up to SHOWN_EACH times as said, else one summary."""
        out = list(self.errors)
        for kind, seen in self.kinds.items():
            first = seen.first[0]
            if seen.times <= SHOWN_EACH:
                out += seen.first
            else:
                rows = f"{seen.rows:,} row{'s' * (seen.rows > 1)}"
                out.append(Diagnostic(self.path, first.line, first.col, f"{kind} on {rows} (first at {seen.where()})",
                                      first.severity))
        out.sort(key=lambda d: (d.line or 0, d.col or 0))
        if self.more_errors is not None:
            first, n = self.more_errors.first[0], self.more_errors.times
            out.append(Diagnostic(self.path, first.line, first.col,
                                  f"{n:,} more error{'s' * (n > 1)} not shown (first at {self.more_errors.where()}): "
                                  f"only the first {MAX_ERRORS} are"))
        return out
