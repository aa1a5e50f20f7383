# st_helpers.py -- helpers for stc's tests: check ST text as one set (the standard library included)
# and get its Program or its errors; run the stc executable as a user does.  A module of its own, not
# conftest.py: pytest collects tests/python at once, and `from conftest import` finds another folder's.

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
STC = ROOT / "st" / "stc"
sys.path.insert(0, str(ROOT / "st"))

from stc_compiler.check import check  # noqa: E402
from stc_compiler.errors import StError, StErrors  # noqa: E402
from stc_compiler.parse import parse_text  # noqa: E402


def compile_st(files: dict[str, str], layout=None):
    """The checked Program of the files (name -> ST text); raises StErrors / StError."""
    return check([parse_text(name, text) for name, text in files.items()], layout)


def errors_of(text: str, name: str = "main.st", layout=None) -> list[StError]:
    try:
        compile_st({name: text}, layout)
    except StErrors as e:
        return e.errors
    except StError as e:
        return [e]
    raise AssertionError("no error for:\n" + text)


def one_error(text: str, name: str = "main.st", layout=None) -> StError:
    errs = errors_of(text, name, layout)
    assert len(errs) == 1, "\n".join(str(e) for e in errs)
    return errs[0]


def program(decls: str, body: str) -> str:
    return f"PROGRAM Main\nVAR\n{decls}\nEND_VAR\n{body}\nEND_PROGRAM\n"


def run_stc(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(STC), *args], cwd=cwd, capture_output=True, text=True, timeout=120)
