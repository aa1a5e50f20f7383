"""uploads.py -- POST /sets bodies: received into a folder inside the data dir while they stream
(limits checked as the bytes arrive), names sanitized, archives unpacked by hand, every file's
kind decided and checked.  Any refusal is an UploadError (an HTTPException: 400 bad name or
content, 413 too large, 415 a kind of file a set does not hold) whose detail says what to fix, and
which names the file, line and column it is about where known (errors.LocatedError).

Bodies: multipart/form-data with `files` parts (the filename is the path in the set, e.g.
"lib/cntr1.so") or one `archive` part (a .tar.gz); or the .tar.gz itself as the body, with
Content-Type application/gzip.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import posixpath
import re
import tarfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

from defusedxml import DTDForbidden, EntitiesForbidden, ExternalReferenceForbidden
from defusedxml import ElementTree as SafeET
from lxml import etree
from python_multipart.multipart import MultipartParser, parse_options_header
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException

from ..dds import bridge_file
from ..dds.bridge_file import BRIDGE_JSON
from ..viewer.mapping import ROBOT_JSON, MappingError, check_against_urdf, parse_config
from ..viewer.urdf import UrdfError
from ..viewer.urdf import parse as parse_urdf
from .archives import tar_stream, type_problem
from .elf_check import MissingSymbol, NotLoadable, check_executable, check_shared_object
from .errors import LocatedError
from .store import StagedFile

MAX_NAME_BYTES = 255
MAX_MODULE_XML_BYTES = 4 << 20  # irpd's own limit (rtcore/src/config/module_xml.hpp)
GZIP_TYPES = ("application/gzip", "application/x-gzip")
ACCEPTED = (
    "module.xml (one, at the root), other .xml configs, .so thread modules and libraries, "
    "the executables module.xml names, .glb, .urdf, .json (robot.json at the root: the 3D view's joint map; dds.json at the root: the DDS bridge's mapping), "
    ".stl/.dae/.obj meshes, .h, .txt, .md, .st (Structured Text: compiled on upload), "
    "PLCopen XML projects (.xml whose root is a PLCopen <project>: imported and compiled on upload)"
)
PLCOPEN_NAMESPACES = "http://www.plcopen.org/xml/"
PERCENT_ESCAPE = re.compile(r"%[0-9A-Fa-f]{2}")


class UploadError(LocatedError):
    """A refused upload: status 400, 413 or 415, a detail that names the file and the fix, and
    where known the file's path in the set, the line and the column (from 1)."""


@dataclass
class Limits:
    max_file_bytes: int = 64 << 20
    max_upload_bytes: int = 256 << 20
    max_files: int = 512

    @classmethod
    def of(cls, settings) -> Limits:
        return cls(settings.max_file_bytes, settings.max_upload_bytes, settings.max_files)


@dataclass
class Received:
    """One file of the upload as received: its path in the set and where its bytes are."""

    path: str
    source: Path
    sha256: str
    size: int


# ---- names ----------------------------------------------------------------------------------
def clean_name(name: str, what: str = "file name") -> str:
    """The normalized relative path of an uploaded name ("./lib//a.so" -> "lib/a.so"), or a 400.

    Refused: empty names, NUL and other control characters, backslashes, percent-escapes (%2e%2e,
    %2f: a name is taken literally, never decoded), absolute paths, '..', names over 255 bytes.
    """
    shown = json.dumps(name)  # quoted and escaped: safe to put in a message
    if not name:
        raise UploadError(400, f"an empty {what}; every file needs its path in the set, e.g. module.xml")
    if "\0" in name:
        raise UploadError(400, f"{what} {shown} contains a NUL character")
    if any(ord(c) < 0x20 or ord(c) == 0x7F for c in name):
        raise UploadError(400, f"{what} {shown} contains a control character")
    if "\\" in name:
        raise UploadError(400, f"{what} {shown} contains a backslash; separate folders with '/'")
    if PERCENT_ESCAPE.search(name):
        raise UploadError(
            400,
            f"{what} {shown} contains a percent-escape ('{PERCENT_ESCAPE.search(name).group()}'); "
            "send the plain name, it is not decoded",
        )
    try:
        length = len(name.encode("utf-8"))
    except UnicodeEncodeError:
        raise UploadError(400, f"{what} {shown} is not valid UTF-8") from None
    if length > MAX_NAME_BYTES:
        raise UploadError(
            400, f"{what} {json.dumps(name[:40])}... is {length} bytes long; the limit is {MAX_NAME_BYTES}"
        )
    if name.startswith("/"):
        raise UploadError(400, f"{what} {shown} is absolute; give the path relative to the set's root")
    parts = [p for p in name.split("/") if p not in ("", ".")]
    if ".." in parts:
        raise UploadError(400, f"{what} {shown} contains '..'; every file must stay inside the set")
    if not parts:
        raise UploadError(400, f"{what} {shown} names no file")
    return "/".join(parts)


# ---- receiving ------------------------------------------------------------------------------
class Sink:
    """One file being written into the staging folder, hashed and counted as it arrives.  A file
    of the set also counts towards the upload's total; an archive (per="upload") has only its own
    limit, its unpacked files count."""

    def __init__(self, receiver: Receiver, path: str, target: Path, limit: int, what: str, per: str = "file"):
        self.receiver, self.path, self.target = receiver, path, target
        self.limit, self.what, self.per = limit, what, per
        self.file = open(target, "xb")
        self.hash = hashlib.sha256()
        self.size = 0

    def write(self, data: bytes) -> None:
        self.size += len(data)
        if self.size > self.limit:
            raise UploadError(413, f"{self.what} is larger than {self.limit} bytes (the limit per {self.per})")
        if self.per == "file":
            self.receiver.count_bytes(len(data))
        self.hash.update(data)
        self.file.write(data)

    def close(self) -> Received:
        self.file.close()
        return Received(self.path, self.target, self.hash.hexdigest(), self.size)


@dataclass
class Receiver:
    """Collects the files of one upload in `staging`, enforcing the limits as bytes arrive."""

    staging: Path
    limits: Limits
    files: list[Received] = field(default_factory=list)
    total: int = 0
    _names: set[str] = field(default_factory=set)
    _serial: int = 0

    def count_bytes(self, n: int) -> None:
        self.total += n
        if self.total > self.limits.max_upload_bytes:
            raise UploadError(
                413, f"the set is larger than {self.limits.max_upload_bytes} bytes (the limit per upload)"
            )

    def open_file(self, name: str) -> Sink:
        path = clean_name(name)
        if path in self._names:
            raise UploadError(400, f"{json.dumps(path)} is in the upload twice", file=path)
        if len(self._names) >= self.limits.max_files:
            raise UploadError(413, f"more than {self.limits.max_files} files in one set (the limit per upload)")
        self._names.add(path)
        self._serial += 1
        return Sink(self, path, self.staging / f"f{self._serial:05d}", self.limits.max_file_bytes, json.dumps(path))

    def open_raw(self, what: str) -> Sink:
        """The archive itself (not a file of the set): counted against the upload limit only."""
        self._serial += 1
        target = self.staging / f"archive{self._serial}.tar.gz"
        return Sink(self, "", target, self.limits.max_upload_bytes, what, "upload")

    def add(self, received: Received) -> None:
        self.files.append(received)


async def receive(request, staging: Path, limits: Limits) -> list[Received]:
    """Reads the request body into `staging`; returns the files of the set (not yet checked)."""
    ctype, options = parse_options_header(request.headers.get("content-type", ""))
    length = request.headers.get("content-length")
    receiver = Receiver(staging, limits)
    # Multipart bodies carry part headers and boundaries beside the files' bytes.
    overhead = 64 * 1024 + 1024 * limits.max_files if ctype == b"multipart/form-data" else 0
    if length is not None and length.isdigit() and int(length) > limits.max_upload_bytes + overhead:
        raise UploadError(413, f"the upload is {length} bytes; the limit is {limits.max_upload_bytes}")
    if ctype == b"multipart/form-data":
        boundary = options.get(b"boundary")
        if not boundary:
            raise UploadError(400, "multipart/form-data without a boundary")
        await _receive_multipart(request, boundary, receiver)
    elif ctype.decode("latin-1") in GZIP_TYPES:
        sink = receiver.open_raw("the .tar.gz body")
        try:
            async for chunk in request.stream():
                await run_in_threadpool(sink.write, chunk)
        finally:
            archive = sink.close()
        await run_in_threadpool(unpack_archive, archive.source, receiver)
    else:
        got = json.dumps(ctype.decode("latin-1"))
        raise UploadError(
            415,
            f"POST /sets takes multipart/form-data (`files` parts or one `archive` part) or a "
            f".tar.gz body with Content-Type application/gzip; got {got}",
        )
    if not receiver.files:
        raise UploadError(400, "the upload holds no files; a set needs at least its module.xml")
    return receiver.files


class _MultipartState:
    """The callbacks of python-multipart's streaming parser: one Sink per part, opened as soon as
    the part's headers are complete, so names and limits are checked before its bytes are kept."""

    def __init__(self, receiver: Receiver):
        self.receiver = receiver
        self.header_field = b""
        self.header_value = b""
        self.headers: dict[bytes, bytes] = {}
        self.sink: Sink | None = None
        self.kind: str | None = None  # "files" or "archive"
        self.archives: list[Received] = []
        self.saw_files = False
        self.ended = False

    def callbacks(self) -> dict:
        return {
            "on_part_begin": self.part_begin,
            "on_header_field": self.header_field_data,
            "on_header_value": self.header_value_data,
            "on_header_end": self.header_end,
            "on_headers_finished": self.headers_finished,
            "on_part_data": self.part_data,
            "on_part_end": self.part_end,
            "on_end": self.end,
        }

    def part_begin(self) -> None:
        self.headers, self.sink, self.kind = {}, None, None

    def header_field_data(self, data: bytes, start: int, end: int) -> None:
        self.header_field += data[start:end]

    def header_value_data(self, data: bytes, start: int, end: int) -> None:
        self.header_value += data[start:end]

    def header_end(self) -> None:
        self.headers[self.header_field.lower()] = self.header_value
        self.header_field = self.header_value = b""

    def headers_finished(self) -> None:
        disposition = self.headers.get(b"content-disposition", b"")
        if b"\\" in disposition:
            raise UploadError(
                400,
                "a part's Content-Disposition contains a backslash; "
                "file names separate folders with '/' and hold no backslash or quote",
            )
        _, params = parse_options_header(disposition)
        name = params.get(b"name", b"").decode("latin-1")
        filename = params.get(b"filename")
        if name == "files":
            if filename is None:
                raise UploadError(400, "a `files` part without a filename; the filename is the file's path in the set")
            if self.archives:
                raise UploadError(400, "send either `files` parts or one `archive` part, not both")
            try:
                text = filename.decode("utf-8")  # the header's raw bytes: browsers send UTF-8
            except UnicodeDecodeError:
                shown = json.dumps(filename.decode("latin-1"))
                raise UploadError(400, f"file name {shown} is not valid UTF-8") from None
            self.sink, self.kind, self.saw_files = self.receiver.open_file(text), "files", True
        elif name == "archive":
            if self.saw_files or self.archives:
                raise UploadError(400, "send one `archive` part, or `files` parts, not both")
            self.sink, self.kind = self.receiver.open_raw("the archive"), "archive"
        else:
            raise UploadError(
                400,
                f"unknown form field {json.dumps(name)}; POST /sets takes `files` parts "
                "(filename = path in the set) or one `archive` part (.tar.gz)",
            )

    def part_data(self, data: bytes, start: int, end: int) -> None:
        self.sink.write(data[start:end])

    def part_end(self) -> None:
        received = self.sink.close()
        if self.kind == "files":
            self.receiver.add(received)
        else:
            self.archives.append(received)
        self.sink = None

    def end(self) -> None:
        self.ended = True


async def _receive_multipart(request, boundary: bytes, receiver: Receiver) -> None:
    state = _MultipartState(receiver)
    parser = MultipartParser(boundary, state.callbacks())
    try:
        async for chunk in request.stream():
            await run_in_threadpool(parser.write, chunk)
        parser.finalize()
    except (UploadError, HTTPException):  # ours, or the body's deadline (security.BodyTimeout)
        raise
    except Exception as e:  # python-multipart's parse errors
        raise UploadError(400, f"the multipart body cannot be read: {e}") from None
    finally:
        if state.sink is not None:
            state.sink.close()
    if not state.ended:
        raise UploadError(400, "the multipart body ended before its closing boundary")
    for archive in state.archives:
        await run_in_threadpool(unpack_archive, archive.source, receiver)


# ---- archives -------------------------------------------------------------------------------
def unpack_archive(archive: Path, receiver: Receiver) -> None:
    """Unpacks a .tar.gz into the receiver: regular files only, each name sanitized (and checked by
    tarfile's "data" filter too), sizes and counts limited as they are read."""
    limits = receiver.limits
    stream_limit = limits.max_upload_bytes + 4096 * (2 * limits.max_files + 8)  # contents + headers
    folders: set[str] = set()
    try:
        with (
            open(archive, "rb") as raw,
            gzip.GzipFile(fileobj=raw, mode="rb") as gz,
            tar_stream(gz, stream_limit, UploadError) as tar,
        ):
            for member in tar:
                shown = json.dumps(member.name)
                problem = type_problem(member, "a set")
                if problem:
                    raise UploadError(400, f"archive member {shown} {problem}")
                if member.isdir() and not [p for p in member.name.split("/") if p not in ("", ".")]:
                    continue  # "./", the archive's own root
                path = clean_name(member.name, "archive member")
                if hasattr(tarfile, "data_filter"):  # Python's own checks, on top of ours
                    try:
                        tarfile.data_filter(member, str(receiver.staging))
                    except tarfile.FilterError as e:
                        raise UploadError(400, f"archive member {shown}: {e}") from None
                if member.isdir():
                    folders.add(path)
                    continue
                if member.size > limits.max_file_bytes:
                    raise UploadError(
                        413,
                        f"archive member {shown} is {member.size} bytes; the limit per file is {limits.max_file_bytes}",
                    )
                sink = receiver.open_file(member.name)
                try:
                    source = tar.extractfile(member)
                    while chunk := source.read(1 << 16):
                        sink.write(chunk)
                finally:
                    received = sink.close()
                receiver.add(received)
    except UploadError:
        raise
    except (tarfile.TarError, gzip.BadGzipFile, zlib.error, EOFError, OSError) as e:
        raise UploadError(400, f"the archive is not a readable .tar.gz: {e}") from None
    _strip_single_folder(receiver)


def _strip_single_folder(receiver: Receiver) -> None:
    """`tar czf set.tar.gz myset/` puts everything under myset/: take that folder as the root (the
    folder holding module.xml, or, in a set written in Structured Text alone, .st files or PLCopen
    XML projects)."""
    paths = [f.path for f in receiver.files]
    if not paths or "module.xml" in paths or any(p.count("/") == 0 for p in paths):
        return
    top = {p.split("/", 1)[0] for p in paths}

    def root_of_a_set(f: Received) -> bool:
        p = f.path.split("/", 1)[1]
        return p == "module.xml" or (
            "/" not in p and (p.lower().endswith(".st") or file_kind(p, f.source) == "plcopen")
        )

    if len(top) == 1 and any(root_of_a_set(f) for f in receiver.files):
        for f in receiver.files:
            f.path = f.path.split("/", 1)[1]


# ---- what the files are ---------------------------------------------------------------------
@dataclass
class ModuleRef:
    name: str  # the module's name (<name>, or the stem of <filename>)
    filename: str  # as written
    path: str  # normalized, relative to the set root
    type: str  # thread | process
    line: int | None = None  # of its <filename> in module.xml
    column: int | None = None
    writes: list[str] = field(default_factory=list)  # <writes>: the shared variables it declares it writes


def _parse_xml(path: Path, shown: str, name: str):
    """Parses XML without DTDs, entities or external references (defusedxml); 400 otherwise.
    `name` is the file's path in the set, `shown` how messages name it."""
    try:
        return SafeET.parse(path, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except DTDForbidden:
        raise UploadError(
            400, f"{shown}: a DOCTYPE/DTD is not allowed (no entity definitions, no XML bombs)", file=name
        ) from None
    except EntitiesForbidden:
        raise UploadError(400, f"{shown}: entity declarations are not allowed (no XML bombs)", file=name) from None
    except ExternalReferenceForbidden:
        raise UploadError(400, f"{shown}: external references are not allowed", file=name) from None
    except SafeET.ParseError as e:
        line, column = e.position  # expat counts columns from 0
        raise UploadError(400, f"{shown}: malformed XML: {e}", file=name, line=line, column=column + 1) from None


def _element_lines(path: Path, root) -> dict[int, tuple[int, int]]:
    """id(element) -> (line, column from 1) of its start tag, for a tree ElementTree parsed from
    `path` (already accepted by defusedxml): expat's start tags come in the order of root.iter()."""
    starts: list[tuple[int, int]] = []
    parser = expat.ParserCreate()
    parser.StartElementHandler = lambda *_: starts.append((parser.CurrentLineNumber, parser.CurrentColumnNumber + 1))
    with open(path, "rb") as f:
        parser.ParseFile(f)
    return {id(e): where for e, where in zip(root.iter(), starts)}


@dataclass
class ModuleXml:
    """What the store needs of module.xml."""

    modules: list[ModuleRef]
    layout: str | None  # <layout>, normalized
    layout_at: dict = field(default_factory=dict)  # {"line", "column"} of <layout>


def parse_module_xml(path: Path) -> ModuleXml:
    """The modules module.xml names and its <layout> (normalized paths).  Only what the store
    needs: irpd's `check` validates the rest."""
    if path.stat().st_size > MAX_MODULE_XML_BYTES:
        raise UploadError(
            400, f"module.xml is larger than {MAX_MODULE_XML_BYTES >> 20} MiB (irpd's limit)", file="module.xml"
        )
    root = _parse_xml(path, "module.xml", "module.xml").getroot()
    lines = _element_lines(path, root)

    def at(node) -> dict:
        line, column = lines.get(id(node), (None, None))
        return {"file": "module.xml", "line": line, "column": column}

    if root.tag != "root":
        raise UploadError(400, f"module.xml: the top-level element is <{root.tag}>, expected <root>", **at(root))
    modules = []
    for i, node in enumerate(root.findall("module"), 1):
        filename_node = node.find("filename")
        filename = (node.findtext("filename") or "").strip()
        stem = posixpath.splitext(posixpath.basename(filename))[0]
        name = (node.findtext("name") or "").strip() or stem or f"#{i}"
        if any(ord(c) < 0x20 or ord(c) == 0x7F for c in name):  # irpd puts module names in its log lines
            name_node = node.find("name")
            raise UploadError(
                400,
                f"module.xml: module <name> {json.dumps(name)} contains a control character "
                "(a newline, a tab, an escape); name modules with printable characters",
                **at(name_node if name_node is not None else node),
            )
        if not filename:
            raise UploadError(
                400,
                f"module.xml: module {json.dumps(name)} has no <filename>",
                **at(node if filename_node is None else filename_node),
            )
        what = f"module.xml: module {json.dumps(name)}: <filename>"
        if filename.startswith("/"):
            raise UploadError(
                400,
                f"{what} {json.dumps(filename)} is absolute; in an uploaded set, name the file relative to module.xml",
                **at(filename_node),
            )
        try:
            normalized = clean_name(filename, what)
        except UploadError as e:
            raise e.at(**at(filename_node)) from None
        kind = (node.findtext("moduletype") or "").strip()
        modules.append(
            ModuleRef(
                name,
                filename,
                normalized,
                kind if kind in ("thread", "process") else "thread" if filename.endswith(".so") else "process",
                at(filename_node)["line"],
                at(filename_node)["column"],
                [(w.text or "").strip() for w in node.findall("writes")],
            )
        )
    layout_node = root.find("layout")
    layout = (root.findtext("layout") or "").strip() or None
    if layout is not None:
        if layout.startswith("/"):
            raise UploadError(
                400,
                f"module.xml: <layout> {json.dumps(layout)} is absolute; name it relative to module.xml",
                **at(layout_node),
            )
        try:
            layout = clean_name(layout, "module.xml: <layout>")
        except UploadError as e:
            raise e.at(**at(layout_node)) from None
    where = at(layout_node) if layout_node is not None else {}
    return ModuleXml(modules, layout, {k: where[k] for k in ("line", "column") if k in where})


def file_kind(path: str, source: Path) -> str | None:
    """A file's kind by its name (and a .glb's first bytes): None when a set does not hold it."""
    base = path.rsplit("/", 1)[-1].lower()
    suffix = posixpath.splitext(base)[1]
    if suffix == ".glb":
        with open(source, "rb") as f:
            return "mesh" if f.read(4) == b"glTF" else "glb"  # binary glTF, or the variables source
    if base == "layout.json":
        return "layout"
    if path == ROBOT_JSON:
        return "robot"
    if path == BRIDGE_JSON:
        return "bridge"
    if suffix == ".xml" and is_plcopen(source):
        return "plcopen"
    return {
        ".so": "library",
        ".xml": "config",
        ".urdf": "urdf",
        ".json": "json",
        ".stl": "mesh",
        ".dae": "mesh",
        ".obj": "mesh",
        ".h": "header",
        ".st": "st",
        ".txt": "text",
        ".md": "text",
    }.get(suffix)


def is_plcopen(source: Path) -> bool:
    """A PLCopen XML project (LD, FBD, SFC, ST drawn in a PLC editor: docs/plcopen-xml.md), compiled like
    .st: its root element is <project> in a namespace of www.plcopen.org/xml (any TC6 version: stc names
    the one it takes).  module.xml, an ioconfig.xml and other .xml are not.  Only the root's start tag
    is read, without DTD or entity."""
    try:
        for _, el in etree.iterparse(
            str(source), events=("start",), resolve_entities=False, load_dtd=False, no_network=True, huge_tree=False
        ):
            name = etree.QName(el)
            return name.localname == "project" and (name.namespace or "").startswith(PLCOPEN_NAMESPACES)
    except (etree.XMLSyntaxError, OSError):
        return False
    return False


def check_set(files: list[Received]) -> list[StagedFile]:
    """Decides every file's kind and checks its content; returns the files ready to commit."""
    by_path = {f.path: f for f in files}
    paths = set(by_path)
    for p in sorted(paths):
        parts = p.split("/")
        for i in range(1, len(parts)):
            if "/".join(parts[:i]) in paths:
                raise UploadError(400, f"{json.dumps('/'.join(parts[:i]))} is both a file and a folder in the upload")
    if "module.xml" not in by_path:
        nested = sorted(p for p in paths if p.rsplit("/", 1)[-1] == "module.xml")
        hint = f"; found {json.dumps(nested[0])}: upload that folder's content" if nested else ""
        raise UploadError(
            400, f"no module.xml at the root of the set (nor .st or PLCopen XML sources to build one from){hint}"
        )
    for p in sorted(paths - {"module.xml"}):
        if p.rsplit("/", 1)[-1] == "module.xml":
            raise UploadError(400, f"{json.dumps(p)}: a set has one module.xml, at its root", file=p)

    xml = parse_module_xml(by_path["module.xml"].source)
    modules, layout = xml.modules, xml.layout
    referenced: dict[str, ModuleRef] = {}
    for m in modules:
        if m.path not in by_path:
            raise UploadError(
                400,
                f"module.xml: module {json.dumps(m.name)} names {json.dumps(m.filename)}, "
                f"which is not in the upload (add it as {json.dumps(m.path)})",
                file="module.xml",
                line=m.line,
                column=m.column,
            )
        other = referenced.setdefault(m.path, m)
        if other.type != m.type:
            raise UploadError(
                400,
                f"module.xml: {json.dumps(m.path)} is both a {other.type} module "
                f"({json.dumps(other.name)}) and a {m.type} module ({json.dumps(m.name)})",
                file="module.xml",
                line=m.line,
                column=m.column,
            )
    if layout is not None and layout not in by_path:
        raise UploadError(
            400,
            f"module.xml: <layout> names {json.dumps(layout)}, which is not in the upload",
            file="module.xml",
            **xml.layout_at,
        )

    staged = []
    for path in sorted(by_path):
        f = by_path[path]
        shown = json.dumps(path)
        ref = referenced.get(path)
        if path == "module.xml":
            kind = "module_xml"
        elif ref is not None:
            kind = "thread_module" if ref.type == "thread" else "executable"
        elif path == layout:
            kind = "layout"
        else:
            kind = file_kind(path, f.source)
        if kind is None:
            raise UploadError(415, f"{shown}: a set does not hold files of this kind; accepted: {ACCEPTED}", file=path)
        _check_content(f, kind, ref, shown)
        staged.append(StagedFile(path, f.source, f.sha256, f.size, kind))
    if ROBOT_JSON in by_path:
        check_robot_json(by_path[ROBOT_JSON].source, {f.path: f for f in staged})
    if BRIDGE_JSON in by_path:
        layout_file = by_path.get(layout or "layout.json")  # irpd's default: layout.json beside module.xml
        check_bridge_json(by_path[BRIDGE_JSON].source, modules, layout_file.source if layout_file else None)
    return staged


def check_bridge_json(source: Path, modules: list[ModuleRef], layout: Path | None) -> None:
    """dds.json's shape, its declared message types and their mappings' fields, one mapping per topic,
    one writer per variable (a second subscription, an import or a module's <writes>), and, when the
    upload holds the layout, every mapped, exported and imported variable in it with a type its field
    fits (docs/dds.md)."""
    try:
        bridge = bridge_file.parse(source.read_bytes())
        bridge_file.check_writers(bridge, {m.name: m.writes for m in modules})
        if layout is not None:
            bridge_file.check_layout(bridge, json.loads(layout.read_bytes()))
    except bridge_file.BridgeFileError as e:
        raise UploadError(400, str(e), file=e.file, line=e.line) from None


def check_robot_json(source: Path, staged: dict[str, StagedFile]) -> None:
    """robot.json names a URDF of the set, and maps movable joints of it (docs/robot-view.md)."""
    try:
        config = parse_config(source.read_bytes())
        urdf = staged.get(config.urdf)
        if urdf is None or urdf.kind != "urdf":
            raise MappingError(
                f'robot.json: "urdf" names {json.dumps(config.urdf)}, which is not a .urdf file of the upload'
            )
        check_against_urdf(config.joints, parse_urdf(urdf.source, config.urdf), ROBOT_JSON, config.urdf)
    except (MappingError, UrdfError) as e:
        raise UploadError(400, str(e)) from None


def _check_content(f: Received, kind: str, ref: ModuleRef | None, shown: str) -> None:
    try:
        if kind == "thread_module":
            check_shared_object(f.source, shown, module=ref.name)
        elif kind == "library":
            check_shared_object(f.source, shown, module=None)
        elif kind == "executable":
            check_executable(f.source, shown, module=ref.name)
    except NotLoadable as e:
        raise UploadError(415, str(e), file=f.path) from None
    except MissingSymbol as e:
        raise UploadError(400, str(e), file=f.path) from None
    if kind == "config" or kind == "urdf" or (kind == "mesh" and f.path.lower().endswith(".dae")):
        _parse_xml(f.source, shown, f.path)
    elif kind in ("layout", "json", "robot", "bridge"):
        try:
            with open(f.source, "rb") as fh:
                json.load(fh)
        except json.JSONDecodeError as e:
            raise UploadError(
                400, f"{shown} is not valid JSON: {e}", file=f.path, line=e.lineno, column=e.colno
            ) from None
        except (ValueError, RecursionError) as e:
            raise UploadError(400, f"{shown} is not valid JSON: {e}", file=f.path) from None
