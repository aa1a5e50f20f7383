"""program_models.py -- the Programs page's API models (routes/programs.py): a set's .st files and
their POUs, a file's source, the check of an edited file (errors and symbols), an applied edit,
a file's history and the diff of two versions (docs/api.md "Programs")."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from .models import SetPublic, SwapReport, Who

MAX_SOURCE_CHARS = 1 << 20  # the agent's request body limit (max_body_bytes) keeps any source below it


class PouOutline(BaseModel):
    name: str
    kind: str = Field(description="PROGRAM, FUNCTION_BLOCK, FUNCTION or CONFIGURATION")
    line: int
    language: str | None = Field(
        None,
        description="a PLCopen XML POU's body: LD, FBD, SFC (opened in the live view), ST or IL; null in a .st file",
    )


class StError(BaseModel):
    file: str = Field(description="the file of the set, e.g. main.st")
    line: int
    column: int = Field(description="from 1, in characters (a tab is one)")
    code: str = Field(description="the compiler's error code (docs/st.md, Errors): type, syntax, undeclared, ...")
    message: str


class ProgramFile(BaseModel):
    path: str
    pous: list[PouOutline]
    error: StError | None = Field(None, description="the file's first error when it cannot be read as ST")
    plcopen: bool = Field(
        False, description="a PLCopen XML file: its graphical POUs open in the live view (GET /programs/diagram)"
    )


class ProgramList(BaseModel):
    set_id: str | None = Field(description="the set listed; null when no set is active (then no files)")
    active: bool
    files: list[ProgramFile]


class ProgramSource(BaseModel):
    set_id: str
    path: str
    sha256: str
    source: str


class CheckRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")
    set: str | None = Field(None, description="the set whose other files it is checked with; default: the active set")
    path: str = Field(description="the .st file of that set being edited", min_length=1, max_length=255)
    source: str = Field(description="the file's text as edited", max_length=MAX_SOURCE_CHARS)


class SymbolParam(BaseModel):
    name: str
    type: str | None = Field(description="an IEC type, or a generic family (ANY_NUM) for standard functions")
    kind: str | None = Field(None, description="VAR_INPUT, VAR_OUTPUT or VAR_IN_OUT")


class SymbolVar(BaseModel):
    name: str
    kind: str = Field(description="VAR, VAR_INPUT, VAR_OUTPUT, VAR_IN_OUT, VAR_TEMP, VAR_EXTERNAL, VAR_GLOBAL")
    type: str | None = Field(description="its IEC type; null where the checker could not type it")
    line: int
    constant: bool = False
    paths: list[str] = Field(
        description="its shared variables: Instance.name for each instance of a PROGRAM, the bound variable of AT"
    )


class SymbolPou(BaseModel):
    name: str
    kind: str
    file: str
    line: int
    vars: list[SymbolVar]


class SymbolGlobal(BaseModel):
    name: str
    type: str | None
    file: str
    line: int
    paths: list[str]


class SymbolFb(BaseModel):
    name: str
    library: bool = Field(description="from st/lib (TON, MC_Power, ...), not the set's")
    params: list[SymbolParam]


class SymbolFunction(BaseModel):
    name: str
    kind: str = Field(description="user, library, or the standard table's: function, conversion, operator, intrinsic")
    result: str | None
    params: list[SymbolParam]
    extensible: bool = False


class Symbols(BaseModel):
    pous: list[SymbolPou] = Field(description="the set's POUs with their variables")
    globals: list[SymbolGlobal]
    fb_types: list[SymbolFb] = Field(description="every function block with its inputs, outputs and in-outs")
    functions: list[SymbolFunction] = Field(description="the set's, st/lib's and the standard functions")


class CheckResult(BaseModel):
    set_id: str
    errors: list[StError]
    symbols: Symbols


class ApplyRequest(CheckRequest):
    activate: bool = Field(False, description="false: store the new set and answer its dry run; true: activate it too")
    mode: Literal["online", "restart", "auto"] = Field("online", description="as POST /sets/{id}/activate")


class ApplyResult(BaseModel):
    set: SetPublic = Field(description="the new set (derived_from: the set and the file), with irpd's dry run")
    report: SwapReport | None = Field(None, description="the activation's report when activate was true")


class FileVersion(BaseModel):
    set_id: str
    created: str
    by: Who | None
    sha256: str
    active: bool
    derived_from: str | None = Field(None, description="the set this one was made from by an edit of this file")


class FileHistory(BaseModel):
    path: str
    versions: list[FileVersion] = Field(description="every stored set holding the file, newest first")


class FileDiff(BaseModel):
    path: str
    old: str = Field(description="the set of the older text")
    new: str = Field(description="the set of the newer text")
    diff: str = Field(description="unified diff text; empty when they are the same")
