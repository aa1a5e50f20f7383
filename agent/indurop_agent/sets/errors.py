"""errors.py -- errors that point into a file of a set: an HTTPException that answers
{"detail", "file", "line", "column", "module", "field"} (those known), with `problems` when there are
several (each {"message", "code", and its place}: a compiler's errors), and `place`, which takes the
place irpd gives an error as fields (protocol/control.json, #/shapes/place) and names its file
relative to the set's folder.  No text is parsed: irpd's messages are for people."""

from __future__ import annotations

from pathlib import Path

from fastapi import HTTPException, Request
from fastapi.responses import JSONResponse

PLACE_FIELDS = ("file", "line", "column", "module", "field")


class LocatedError(HTTPException):
    """An HTTP error whose detail is about a file of a set: `file` relative to the set's root,
    `line` and `column` counted from 1, the `module` and the module.xml `field` (None: not known)."""

    def __init__(
        self,
        status_code: int,
        detail: str,
        *,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        module: str | None = None,
        field: str | None = None,
        headers: dict | None = None,
        problems: list[dict] | None = None,
    ):
        super().__init__(status_code, detail, headers=headers)
        self.file, self.line, self.column, self.module, self.field = file, line, column, module, field
        self.problems = problems

    def at(self, file: str | None = None, line: int | None = None, column: int | None = None) -> LocatedError:
        """Adds what is known of where (keeps what was already set); returns self, to re-raise."""
        self.file = self.file or file
        self.line = self.line or line
        self.column = self.column or column
        return self

    def body(self) -> dict:
        out = {"detail": self.detail}
        for key in PLACE_FIELDS:
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        if self.problems is not None:
            out["problems"] = self.problems
        return out


async def located_error(_: Request, exc: LocatedError) -> JSONResponse:
    return JSONResponse(status_code=exc.status_code, content=exc.body(), headers=exc.headers)


def place(fields: dict | None, root: Path | str | None = None) -> dict:
    """The known fields of an error's place as irpd gives them ({"file", "line", "column",
    "module", "field"}, any of them).  With `root` (a set's folder), a file inside it comes back
    relative to it ("module.xml", "lib/cntr1.so") and a file outside it is left out."""
    if not isinstance(fields, dict):
        return {}
    out = {key: fields[key] for key in PLACE_FIELDS if fields.get(key) not in (None, "", 0)}
    if "file" in out and root is not None:
        relative = _inside(Path(out["file"]), Path(root))
        if relative is None:
            del out["file"]
        else:
            out["file"] = relative
    return out


def _inside(file: Path, root: Path) -> str | None:
    """`file` relative to `root` ("lib/x.so"), or None when it is outside it."""
    for base in (root, root.resolve()):
        try:
            return file.relative_to(base).as_posix()
        except ValueError:
            continue
    return None


def problems(found: list, root: Path | str | None = None) -> list[dict]:
    """irpd's problems ({"message", and the place's fields}) with their files relative to `root`."""
    return [{"message": str(p.get("message", "")), **place(p, root)} for p in found if isinstance(p, dict)]
