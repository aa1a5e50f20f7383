"""errors.py -- errors that point into a file of a set: an HTTPException that answers
{"detail", "file", "line", "column"} (the last three where known), and `locate`, which finds where
one of irpd's messages points ("<path>/module.xml:12: module 'x': ...")."""

from __future__ import annotations

import re
from pathlib import Path

from fastapi import HTTPException, Request
from fastapi.responses import JSONResponse

# "<file>:<line>[:<column>]: " or "<file>: " at the start of a message (a file name holds no
# colon and no white space).
WHERE = re.compile(r"^(?P<file>[^:\s]+)(?::(?P<line>\d+))?(?::(?P<column>\d+))?: ")


class LocatedError(HTTPException):
    """An HTTP error whose detail is about a file of a set: `file` relative to the set's root,
    `line` and `column` counted from 1 (None: not known)."""

    def __init__(
        self,
        status_code: int,
        detail: str,
        *,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        headers: dict | None = None,
    ):
        super().__init__(status_code, detail, headers=headers)
        self.file, self.line, self.column = file, line, column

    def at(self, file: str | None = None, line: int | None = None, column: int | None = None) -> LocatedError:
        """Adds what is known of where (keeps what was already set); returns self, to re-raise."""
        self.file = self.file or file
        self.line = self.line or line
        self.column = self.column or column
        return self

    def body(self) -> dict:
        out = {"detail": self.detail}
        for key in ("file", "line", "column"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        return out


async def located_error(_: Request, exc: LocatedError) -> JSONResponse:
    return JSONResponse(status_code=exc.status_code, content=exc.body(), headers=exc.headers)


def locate(message: str, root: Path | str | None = None) -> dict:
    """Where `message` points: {"file", "line", "column"} with the keys known (maybe none).

    With `root` (a set's folder), only paths inside it count, and come back relative to it
    ("module.xml", "lib/cntr1.so"); without, only a leading "<path>:<line>: " counts, as it is.
    """
    m = WHERE.match(message)
    if m is None:
        return {}
    file = m.group("file")
    if root is not None:
        base = str(Path(root)).rstrip("/") + "/"
        if not file.startswith(base):
            return {}
        file = file[len(base) :]
    elif m.group("line") is None:
        return {}
    where = {"file": file}
    if m.group("line"):
        where["line"] = int(m.group("line"))
    if m.group("column"):
        where["column"] = int(m.group("column"))
    return where


def problems(messages: list[str], root: Path | str | None = None) -> list[dict]:
    """Each message with where it points: [{"message", "file"?, "line"?, "column"?}]."""
    return [{"message": m, **locate(m, root)} for m in messages]
