"""st_build.py -- sets with Structured Text: an upload that holds .st files (or PLCopen XML projects,
LD/FBD/SFC/ST drawn in a PLC editor) is compiled here, before
its files are checked, by `stc build` (st/, docs/st.md) run on a copy of it, so that
the stored set holds its sources and what was built from them (module.xml, layout.json, one .so per
PROGRAM instance) and irpd loads it like any other.  Laid out against the running layout
(`--previous`) so that the activation can be online; the set's own .glb files and layout.json, and
its hand-written module.xml, go in as `--glb`, `--set-layout`, `--module-xml`.

The build runs in a process group of its own with a time limit (settings.st_build_timeout_s: the
group is killed), size limits (no file it writes may reach max_upload_bytes: RLIMIT_FSIZE, inherited
by the C++ compiler; what it built must fit max_file_bytes, max_files and max_upload_bytes like an
upload) and its output captured into files.  stc's input errors ({file, line, column,
code, message}, file relative to the set) refuse the upload with every error as a problem."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

from .errors import place
from .store import remove_tree
from .uploads import Limits, Received, UploadError, file_kind, parse_module_xml

ST_SUFFIX = ".st"
INSTALLED_STC = Path("/usr/share/indurop/st/stc")
BUILDING = threading.Lock()  # one build at a time (see build())
OUTPUT_KEPT = 1 << 20  # the compiler's output read back (stdout: the errors as JSON; stderr: shown on a failure)
SHOWN_ERRORS = 5  # the errors the detail spells out; `problems` has them all
# Runs stc (argv[2:]) with no file it, or g++ under it, may write reaching argv[1] bytes.
# stc and the C++ compiler it runs: files bounded by the upload limit, and the lowest CPU priority
# (nice 19), so that a set compiling on the appliance leaves the agent's own work (the recorder reading
# the trace rings, OPC UA, the API) its share of the CPU.
LAUNCH = (
    "import os, resource, sys; n = int(sys.argv[1]); resource.setrlimit(resource.RLIMIT_FSIZE, (n, n)); "
    "os.nice(19); os.execv(sys.argv[2], sys.argv[2:])"
)


class StBuildError(UploadError):
    """The ST sources did not build: the detail says why; `problems` holds stc's errors."""


def sources(files: list[Received]) -> list[str]:
    """The paths of what stc compiles: .st files and PLCopen XML projects (uploads.is_plcopen)."""
    return sorted(
        f.path for f in files if f.path.lower().endswith(ST_SUFFIX) or file_kind(f.path, f.source) == "plcopen"
    )


def has_st(files: list[Received]) -> bool:
    return bool(sources(files))


def find_stc(configured: Path | None) -> Path:
    """settings.stc, else st/stc of this source tree, else stc on the PATH, else the installed one."""
    if configured is not None:
        return configured
    here = Path(__file__).resolve().parents[3] / "st" / "stc"
    if here.is_file():
        return here
    found = shutil.which("stc")
    return Path(found) if found else INSTALLED_STC


def build(
    files: list[Received], staging: Path, limits: Limits, stc: Path, timeout_s: float, previous: bytes | None
) -> list[Received]:
    """The upload's files with what `stc build` made of its .st files added (replacing files of the
    same path: a hand-written module.xml gives way to the one with the ST programs in it); the files
    unchanged when it holds none.  `staging`: the upload's folder, where the built files are put;
    `previous`: the running layout.json, or None when irpd runs none.

    One build at a time, always in the same folder (`<data>/tmp/st-build`): the C++ compiler writes
    the folder it ran in into the modules' debug information, so the same sources give the same
    modules, hence the same set id, and two uploads do not share the machine's cores."""
    if not has_st(files):
        return files
    work = staging.parent / "st-build"
    with BUILDING:
        remove_tree(work)
        try:
            return _build(files, work, staging, limits, stc, timeout_s, previous)
        finally:
            remove_tree(work)


def _build(files, work: Path, staging: Path, limits: Limits, stc: Path, timeout_s: float, previous) -> list[Received]:
    """The build runs in `work/set`, a copy of the upload (copies, not links: what stc writes there
    must not change the received files), with the set's root as its output folder, so that the
    paths in the module.xml it writes are the set's."""
    root = work / "set"
    root.mkdir(parents=True)
    by_path = {f.path: f for f in files}
    for f in files:
        target = root / f.path
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(f.source, target)
    args = ["build", "-o", ".", "--json"]
    # `--option=value` and `--` before the sources: a file named "-x.st" is a file, not an option
    args += [f"--glb={p}" for p in sorted(by_path) if file_kind(p, by_path[p].source) == "glb"]
    layout = set_layout(by_path)
    if layout is not None:
        args += [f"--set-layout={layout}"]
    if previous is not None:
        (work / "previous.json").write_bytes(previous)
        args += [f"--previous={work / 'previous.json'}"]
    if "module.xml" in by_path:
        args += ["--module-xml", "module.xml"]
    args += ["--", *sources(files)]
    _run(stc, args, root, work, limits, timeout_s)
    return _with_outputs(by_path, root, staging, limits)


def set_layout(by_path: dict[str, Received]) -> str | None:
    """The set's own layout: module.xml's <layout>, else layout.json beside it (irpd's default)."""
    if "module.xml" in by_path:
        named = parse_module_xml(by_path["module.xml"].source).layout
        if named is not None and named in by_path:
            return named
    return "layout.json" if "layout.json" in by_path else None


def _run(stc: Path, args: list[str], cwd: Path, work: Path, limits: Limits, timeout_s: float) -> None:
    if not stc.is_file():
        raise StBuildError(500, f"the set holds .st files but the ST compiler is not installed here ({stc})")
    command = [sys.executable, "-c", LAUNCH, str(limits.max_upload_bytes), sys.executable, str(stc), *args]
    with open(work / "stdout", "wb") as stdout, open(work / "stderr", "wb") as stderr:
        proc = subprocess.Popen(
            command, cwd=cwd, stdin=subprocess.DEVNULL, stdout=stdout, stderr=stderr, start_new_session=True
        )
        try:
            proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            raise StBuildError(
                400,
                f"compiling the set's ST sources took longer than {timeout_s:g} s (st_build_timeout_s) and was "
                "stopped; make the program smaller, or raise st_build_timeout_s in the agent's settings",
            ) from None
        finally:
            if proc.returncode is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    _kill_group_leftovers(proc.pid)
    said = _read(work / "stdout")
    if proc.returncode == 0:
        return
    # A write cut at the size limit fails stc (which ignores SIGXFSZ) in its own words: the file that
    # reached the limit says what happened.
    full = [p for p in cwd.rglob("*") if p.is_file() and p.stat().st_size >= limits.max_upload_bytes]
    if full or proc.returncode == -signal.SIGXFSZ:
        shown = f" ({full[0].relative_to(cwd).as_posix()})" if full else ""
        raise StBuildError(
            413,
            f"compiling the set's ST sources wrote a file{shown} of {limits.max_upload_bytes} bytes "
            "(max_upload_bytes, the limit of a whole set) and was stopped",
        )
    if proc.returncode == 1:
        raise _input_errors(said, cwd)
    stderr = _read(work / "stderr").decode("utf-8", "replace").strip()
    raise StBuildError(
        500,
        f"the ST compiler failed (exit status {proc.returncode}) on sources it accepted: "
        + (stderr[-4000:] or "it said nothing"),
    )


def _kill_group_leftovers(pgid: int) -> None:
    """A compiler child that outlived stc (the group is stc's own) is stopped too."""
    try:
        os.killpg(pgid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):  # none left (the group's id is no longer ours)
        pass


def _read(path: Path) -> bytes:
    with open(path, "rb") as f:
        return f.read(OUTPUT_KEPT)


def _input_errors(said: bytes, src: Path) -> StBuildError:
    """stc's exit 1: its JSON list of {file, line, column, code, message}, as the refusal's problems,
    files relative to the set (`src`: where the build read it; a file outside it is left out)."""
    try:
        problems = [
            {
                "message": str(e["message"]),
                "code": str(e["code"]),
                **({"origin": str(e["origin"])} if e.get("origin") else {}),
                **place({**e, "file": str(src / e["file"])}, src),
            }
            for e in json.loads(said)
        ]
    except (ValueError, TypeError, KeyError):
        return StBuildError(400, f"the set's ST sources do not compile: {said[:2000].decode('utf-8', 'replace')}")
    if not problems:
        return StBuildError(400, "the set's ST sources do not compile (the compiler named no error)")
    lines = [error_line(p) for p in problems[:SHOWN_ERRORS]]
    more = f"\n(and {len(problems) - SHOWN_ERRORS} more)" if len(problems) > SHOWN_ERRORS else ""
    first = problems[0]
    count = f"{len(problems)} error{'s' if len(problems) > 1 else ''}"
    return StBuildError(
        400,
        f"the set's ST sources do not compile ({count}):\n" + "\n".join(lines) + more,
        file=first.get("file"),
        line=first.get("line"),
        column=first.get("column"),
        problems=problems,
    )


def error_line(p: dict) -> str:
    """`main.st:12:9: error[type]: message`, as stc prints it (with the drawn element it is in, for a
    PLCopen XML file: `plc.xml:40:1: error[undeclared]: main (LD) rung 4, contact localId 17: ...`)."""
    where = ":".join(str(p[k]) for k in ("file", "line", "column") if p.get(k))
    origin = f"{p['origin']}: " if p.get("origin") else ""
    return f"{where + ': ' if where else ''}error[{p.get('code')}]: {origin}{p.get('message')}"


def _with_outputs(by_path: dict[str, Received], root: Path, staging: Path, limits: Limits) -> list[Received]:
    """The set after the build: the files stc wrote (module.xml, layout.json, the modules' .so, and a
    received file it wrote anew, such as the layout's header) moved into `staging`, with the
    received files it left alone.  Its C++ (`<Instance>.cpp`) is not kept: a set holds no sources
    the appliance does not read."""
    if not (root / "module.xml").is_file():
        raise StBuildError(500, "the ST compiler reported success but wrote no module.xml")
    out: list[Received] = []
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root).as_posix()
        if not p.is_file() or p.is_symlink():
            continue
        sha256, size = _hash(p)
        received = by_path.get(rel)
        if received is not None and received.sha256 == sha256:
            out.append(received)
        elif received is not None or rel in ("module.xml", "layout.json") or rel.endswith(".so"):
            if size > limits.max_file_bytes:
                raise StBuildError(
                    413,
                    f"the ST compiler built {json.dumps(rel)} of {size} bytes; the limit per file of a set is "
                    f"{limits.max_file_bytes} (max_file_bytes)",
                    file=rel,
                )
            staged = staging / f"built{len(out):05d}"
            os.replace(p, staged)
            out.append(Received(rel, staged, sha256, size))
    if len(out) > limits.max_files:
        raise StBuildError(413, f"with what the ST compiler built, the set has more than {limits.max_files} files")
    if sum(f.size for f in out) > limits.max_upload_bytes:
        raise StBuildError(
            413, f"with what the ST compiler built, the set is larger than {limits.max_upload_bytes} bytes"
        )
    return out


def _hash(path: Path) -> tuple[str, int]:
    digest, size = hashlib.sha256(), 0
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            digest.update(chunk)
            size += len(chunk)
    return digest.hexdigest(), size
