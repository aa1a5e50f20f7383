# errors.py -- glbc's diagnostics: a source position, and an error that prints as
# `file:line:col: error: message` followed by the source line and a caret under the column.

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Source:
    """One input file: its name as given on the command line and its text split in lines."""

    name: str
    text: str
    lines: tuple[str, ...]

    @staticmethod
    def from_text(name: str, text: str) -> Source:
        # splitlines() would also split at \f, \v, \x1c.. which the lexer treats as plain
        # characters; split at \n only and drop a \r before it.
        return Source(name, text, tuple(line.rstrip("\r") for line in text.split("\n")))

    def line(self, number: int) -> str:
        return self.lines[number - 1] if 1 <= number <= len(self.lines) else ""


@dataclass(frozen=True)
class Loc:
    """A position in a source: 1-based line and column (a column counts characters, a tab is one)."""

    source: Source
    line: int
    col: int
    length: int = 1  # characters to underline

    def __str__(self) -> str:
        return f"{self.source.name}:{self.line}:{self.col}"

    def short(self) -> str:
        """`file:line`, as layout.json's `source` fields give it."""
        return f"{self.source.name}:{self.line}"

    def excerpt(self) -> str:
        """The source line with a gutter, and a caret (and tildes) under the position."""
        text = self.source.line(self.line)
        gutter = f"{self.line:5d} | "
        # Keep tabs in the caret line so that it lines up with the source line.
        pad = "".join("\t" if c == "\t" else " " for c in text[: self.col - 1])
        width = max(1, min(self.length, len(text) - (self.col - 1)))
        marker = "^" + "~" * (width - 1)
        return f"{gutter}{text}\n{' ' * 5} | {pad}{marker}"


@dataclass
class Note:
    loc: Loc
    message: str


@dataclass
class GlbError(Exception):
    """An input error: exit status 1.  `loc` is None for errors about a whole file."""

    message: str
    loc: Loc | None = None
    file: str | None = None  # when loc is None: the file the error is about
    notes: list[Note] = field(default_factory=list)

    def __str__(self) -> str:
        return self.format()

    def format(self) -> str:
        if self.loc is None:
            where = f"{self.file}: " if self.file else "glbc: "
            out = [f"{where}error: {self.message}"]
        else:
            out = [f"{self.loc}: error: {self.message}", self.loc.excerpt()]
        for note in self.notes:
            out.append(f"{note.loc}: note: {note.message}")
            out.append(note.loc.excerpt())
        return "\n".join(out)
