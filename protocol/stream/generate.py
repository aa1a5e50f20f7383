#!/usr/bin/env python3
"""generate.py -- writes everything that follows from protocol/stream/frame.json, the one description
of the stream's binary frame (WebSocket /api/v1/stream):

  agent/indurop_agent/api/stream_frame_spec.py   constants of the Python encoder and decoder
  webui/src/stream/frame_spec.ts                 constants of the TypeScript decoder
  protocol/stream/vectors.json                   frames and what they decode to (or why they are refused),
                                                 decoded by the Python and the TypeScript tests
  docs/trace-and-stream.md                       the frame's table, between its "generated" markers

    python3 protocol/stream/generate.py           # rewrite them
    python3 protocol/stream/generate.py --check   # exit 1 naming the stale ones (the tests run this)

Standard library only.  Offsets are computed here from the order and sizes of the fields, with
no padding; every field must sit on a multiple of its size, and the header on a multiple of 8, so
that the decoders may view the body as typed arrays.
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "protocol"))
from generated_files import write_or_check  # noqa: E402

SPEC = ROOT / "protocol" / "stream" / "frame.json"
PYTHON = ROOT / "agent" / "indurop_agent" / "api" / "stream_frame_spec.py"
TYPESCRIPT = ROOT / "webui" / "src" / "stream" / "frame_spec.ts"
VECTORS = ROOT / "protocol" / "stream" / "vectors.json"
DOC = ROOT / "docs" / "trace-and-stream.md"
COMMAND = "python3 protocol/stream/generate.py"
DOC_BEGIN = (
    "<!-- stream frame: generated from protocol/stream/frame.json by protocol/stream/generate.py; do not edit -->"
)
DOC_END = "<!-- end of the generated stream frame -->"

CODES = {"u8": "B", "u16": "H", "u32": "I", "u64": "Q", "i64": "q", "f64": "d"}
SIZES = {"u8": 1, "u16": 2, "u32": 4, "u64": 8, "i64": 8, "f64": 8}


class SpecError(Exception):
    pass


def load(path: Path = SPEC) -> dict:
    """The spec, checked, with each header field's offset and the header's struct format added."""
    spec = json.loads(path.read_text())
    if spec.get("byte_order") != "little":
        raise SpecError(f"{path}: byte_order must be little (the decoders view the body as typed arrays)")
    at, fmt = 0, "<"
    for f in spec["header"]:
        if f["type"] == "bytes":
            size, code = f["size"], f"{f['size']}s"
        elif f["type"] in CODES:
            size, code = SIZES[f["type"]], CODES[f["type"]]
        else:
            raise SpecError(
                f"{path}: header field {f['name']} has type {f['type']!r}; known: bytes, {', '.join(CODES)}"
            )
        if f["type"] != "bytes" and at % size:
            raise SpecError(f"{path}: header field {f['name']} at offset {at} is not on a multiple of its size {size}")
        f["offset"], f["size"] = at, size
        at, fmt = at + size, fmt + code
    if at % 8:
        raise SpecError(f"{path}: the header is {at} bytes; it must be a multiple of 8 for the body's typed arrays")
    if spec["header"][0]["name"] != "magic" or spec["header"][0]["size"] != len(spec["magic"]):
        raise SpecError(f"{path}: the header must open with the {len(spec['magic'])}-byte magic")
    names = {f["name"] for f in spec["header"]}
    for b in spec["body"]:
        if b["type"] not in CODES or SIZES[b["type"]] != 8:
            raise SpecError(f"{path}: body part {b['name']} must be of an 8-byte type")
        for ref in (b["count"], b.get("repeat")):
            if ref is not None and ref not in names:
                raise SpecError(f"{path}: body part {b['name']} counts by {ref!r}, which is not a header field")
    spec["header_size"], spec["header_format"] = at, fmt
    return spec


def encode(spec: dict, values: dict) -> bytes:
    """A frame from header values and body values by name: the spec's own packer, independent of
    the agent's encoder, used to write the vectors."""
    header = {**values, "magic": values.get("magic", spec["magic"].encode())}
    out = struct.pack(spec["header_format"], *(header.get(f["name"], 0) for f in spec["header"]))  # others: 0
    for b in spec["body"]:
        n = header[b["count"]]
        parts = values[b["name"]] if b.get("repeat") else [values[b["name"]]]
        for part in parts:
            assert len(part) == n, f"{b['name']}: {len(part)} values, the header says {n}"
            out += struct.pack(f"<{n}{CODES[b['type']]}", *part)
    return out


def with_field(spec: dict, frame: bytes, name: str, value: int) -> bytes:
    """`frame` with one header field changed."""
    f = next(f for f in spec["header"] if f["name"] == name)
    raw = bytearray(frame)
    struct.pack_into("<" + CODES[f["type"]], raw, f["offset"], value)
    return bytes(raw)


# ---- the outputs -------------------------------------------------------------------------------
def python_module(spec: dict) -> str:
    kinds = {k: v["value"] for k, v in spec["kinds"].items()}
    fields = tuple(f["name"] for f in spec["header"])
    offsets = {f["name"]: f["offset"] for f in spec["header"]}
    formats = {f["name"]: f"{f['size']}s" if f["type"] == "bytes" else CODES[f["type"]] for f in spec["header"]}
    body = tuple((b["name"], CODES[b["type"]], b["count"], b.get("repeat")) for b in spec["body"])
    return (
        f'"""stream_frame_spec.py -- the stream frame\'s constants, GENERATED from protocol/stream/frame.json by\n'
        f'protocol/stream/generate.py: do not edit; change the spec and run `{COMMAND}`.\n'
        f'The encoder and decoder that use them: stream_frame.py."""\n\n'
        f"MAGIC = {spec['magic'].encode()!r}\n"
        f"VERSION = {spec['version']}\n"
        f"KINDS = {kinds!r}\n"
        f"HEADER_FORMAT = {spec['header_format']!r}\n"
        f"HEADER_SIZE = {spec['header_size']}\n"
        f"HEADER_FIELDS = {fields!r}\n"
        f"OFFSETS = {offsets!r}\n"
        f"FORMATS = {formats!r}  # struct code of each header field\n"
        f"# (name, struct code of each value, header field giving the values' count, header field giving\n"
        f"# how many such runs follow one another or None), in frame order\n"
        f"BODY = {body!r}\n"
    )


def typescript_module(spec: dict) -> str:
    magic = int.from_bytes(spec["magic"].encode(), "little")
    lines = [
        "// frame_spec.ts -- the stream frame's constants, GENERATED from protocol/stream/frame.json by",
        f"// protocol/stream/generate.py: do not edit; change the spec and run `{COMMAND}`.",
        "// The decoder that uses them: frame.ts.",
        f'export const FRAME_MAGIC_TEXT = "{spec["magic"]}";',
        f"export const FRAME_MAGIC = 0x{magic:08x}; // those bytes as a little-endian u32",
        f"export const FRAME_VERSION = {spec['version']};",
    ]
    for k, v in spec["kinds"].items():
        lines.append(f"export const FRAME_KIND_{k.upper()} = {v['value']};")
    lines.append(f"export const HEADER_BYTES = {spec['header_size']};")
    lines.append("/** offset and type of each header field (little-endian) */")
    lines.append("export const FIELDS = {")
    for f in spec["header"]:
        lines.append(f'  {f["name"]}: {{ offset: {f["offset"]}, type: "{f["type"]}" }},')
    lines.append("} as const;")
    lines.append("/** the body, in frame order: `count` values of `type`, `repeat` times (1 when null) */")
    lines.append("export const BODY = [")
    for b in spec["body"]:
        repeat = f'"{b["repeat"]}"' if b.get("repeat") else "null"
        lines.append(f'  {{ name: "{b["name"]}", type: "{b["type"]}", count: "{b["count"]}", repeat: {repeat} }},')
    lines.append("] as const;")
    return "\n".join(lines) + "\n"


def vectors(spec: dict) -> str:
    """Frames that decode (with what they decode to) and frames that are refused (with why)."""
    samples = spec["kinds"]["samples"]["value"]
    base = {"version": spec["version"], "kind": samples}
    good = [
        (
            "three samples of two channels",
            {
                "first_seq": 4242,
                "dropped": 17,
                "t_ns": [123456789012345, 123456789112345, 123456789212345],
                "columns": [[1.5, -2.0, 3.0], [0.0, 1e300, -0.0]],
            },
        ),
        ("no samples", {"first_seq": 1, "dropped": 0, "t_ns": [], "columns": []}),
        ("samples without channels", {"first_seq": 9, "dropped": 0, "t_ns": [1, 2], "columns": []}),
        (
            "negative times, large seq and drop counter",
            {"first_seq": 2**52, "dropped": 2**40, "t_ns": [-5, 0, 2**52], "columns": [[0.25, 0.5, 0.75]]},
        ),
    ]
    out = {
        "about": f"GENERATED from protocol/stream/frame.json by protocol/stream/generate.py: do not edit; "
        f"run `{COMMAND}`. Every number here is exact in a double.",
        "decode": [],
        "refuse": [],
    }
    for name, v in good:
        values = {**base, **v, "count": len(v["t_ns"]), "channels": len(v["columns"])}
        out["decode"].append(
            {
                "name": name,
                "hex": encode(spec, values).hex(),
                "frame": {k: values[k] for k in ("first_seq", "count", "channels", "dropped", "t_ns", "columns")},
            }
        )
    one = {**base, "first_seq": 1, "dropped": 0, "t_ns": [10, 20], "columns": [[2.0, 3.0]], "count": 2, "channels": 1}
    ok = encode(spec, one)
    refused = [
        ("shorter than its header", ok[:10], "short"),
        ("another magic", b"XXXX" + ok[4:], "magic"),
        ("another version", with_field(spec, ok, "version", spec["version"] + 1), "version"),
        ("another kind", with_field(spec, ok, "kind", samples + 2), "kind"),
        ("cut short", ok[:-9], "length"),
        ("a byte too many", ok + b"\0", "length"),
        ("a header announcing 1000 channels", with_field(spec, ok, "channels", 1000), "length"),
    ]
    for name, raw, why in refused:
        out["refuse"].append({"name": name, "hex": raw.hex(), "error": why})
    return json.dumps(out, indent=1) + "\n"


def doc_table(spec: dict) -> str:
    rows = ["| offset | type | field | meaning |", "| ---: | --- | --- | --- |"]
    for f in spec["header"]:
        t = f"{f['size']} bytes" if f["type"] == "bytes" else f["type"]
        rows.append(f"| {f['offset']} | {t} | `{f['name']}` | {f['meaning']} |")
    at = str(spec["header_size"])
    for b in spec["body"]:
        n = f"`{b['count']}`" + (f" × `{b['repeat']}`" if b.get("repeat") else "")
        rows.append(f"| {at} | {b['type']} × {n} | `{b['name']}` | {b['meaning']} |")
        size = f"8 × {b['count']}" + (f" × {b['repeat']}" if b.get("repeat") else "")
        at = f"{at} + {size}"
    kinds = ", ".join(f"{v['value']} {k}" for k, v in spec["kinds"].items())
    return "\n".join(
        [
            DOC_BEGIN,
            "",
            f"Version {spec['version']}, {spec['byte_order']}-endian, {spec['header_size']}-byte header, "
            f"no padding; kinds: {kinds}.",
            "",
            *rows,
            "",
            DOC_END,
        ]
    )


def document(spec: dict, text: str) -> str:
    if DOC_BEGIN not in text or DOC_END not in text:
        raise SpecError(f"{DOC} has lost its markers; put them back around the frame's table:\n{DOC_BEGIN}\n{DOC_END}")
    head, rest = text.split(DOC_BEGIN, 1)
    _, tail = rest.split(DOC_END, 1)
    return head + doc_table(spec) + tail


def outputs(spec: dict) -> dict[Path, str]:
    return {
        PYTHON: python_module(spec),
        TYPESCRIPT: typescript_module(spec),
        VECTORS: vectors(spec),
        DOC: document(spec, DOC.read_text()),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 naming the stale files")
    args = parser.parse_args()
    try:
        spec = load()
        files = outputs(spec)
    except (SpecError, OSError, ValueError, KeyError) as e:
        print(f"generate.py: {e}", file=sys.stderr)
        return 2
    return write_or_check(files, args.check, COMMAND, ROOT)


if __name__ == "__main__":
    sys.exit(main())
