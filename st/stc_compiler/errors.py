# errors.py -- stc's structured errors: file, line, column, a short code and a message that names the
# fix; printed as `file:line:col: error[code]: message`, or as JSON by cli.py.

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Place:
    """Where a node starts: the file as given, 1-based line and column (a tab counts one).  `origin`:
    for a node translated from a graphical body (PLCopen XML, plcopen/), the element it came from,
    e.g. `main (LD) rung 4, contact localId 17`; printed before the message."""

    file: str
    line: int
    col: int
    origin: str = ""

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"


class StError(Exception):
    """One error of the source: where, a code (e.g. `syntax`, `type`, `undeclared`) and what to change."""

    def __init__(self, place: Place, code: str, message: str) -> None:
        where = f"{place.origin}: " if place.origin else ""
        super().__init__(f"{place}: error[{code}]: {where}{message}")
        self.place = place
        self.code = code
        self.message = message

    @property
    def file(self) -> str:
        return self.place.file

    @property
    def line(self) -> int:
        return self.place.line

    @property
    def col(self) -> int:
        return self.place.col

    def format(self) -> str:
        return str(self)

    def as_json(self) -> dict:
        found = {"file": self.file, "line": self.line, "column": self.col, "code": self.code, "message": self.message}
        if self.place.origin:
            found["origin"] = self.place.origin
        return found


class StErrors(Exception):
    """Every error a pass found (at least one), in source order."""

    def __init__(self, errors: list[StError]) -> None:
        super().__init__("\n".join(str(e) for e in errors))
        self.errors = errors


class Collector:
    """Gathers the errors of a pass so that one run reports them all; one error per place and code."""

    def __init__(self) -> None:
        self.errors: list[StError] = []
        self._seen: set[tuple] = set()

    def add(self, place: Place, code: str, message: str) -> None:
        key = (place, code)
        if key not in self._seen:
            self._seen.add(key)
            self.errors.append(StError(place, code, message))

    def raise_if_any(self) -> None:
        if self.errors:
            self.errors.sort(key=lambda e: (e.file, e.line, e.col))
            raise StErrors(self.errors)
