#!/usr/bin/env python3
"""generate.py -- writes what follows from irpd's description of its shared-memory segments
(`irpd --print-shm-layout`, made from the C structs by rtcore/src/shm/):

  agent/indurop_agent/irpd/shm_layout.json   the description itself, which the agent's readers take
                                             every offset from (irpd/shm_layout.py)
  docs/shared-memory.md                      the segments' field tables, between its "generated" markers

    ninja -C build shm-layout                                  # builds irpd, then runs this
    python3 protocol/shm/generate.py --irpd build/bin/irpd     # the same, irpd already built
    python3 protocol/shm/generate.py --irpd build/bin/irpd --check   # exit 1 naming the stale ones

Standard library only.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "protocol"))
from generated_files import write_or_check  # noqa: E402

DESCRIPTION = ROOT / "agent" / "indurop_agent" / "irpd" / "shm_layout.json"
DOC = ROOT / "docs" / "shared-memory.md"
COMMAND = "ninja -C build shm-layout"
DOC_BEGIN = "<!-- segments: generated from `irpd --print-shm-layout` by protocol/shm/generate.py; do not edit -->"
DOC_END = "<!-- end of the generated segments -->"


def type_name(field: dict) -> str:
    return f"{field['type']}[{field['count']}]" if "count" in field else field["type"]


def cell(text: str) -> str:
    return text.replace("|", "\\|")


def segment_doc(name: str, s: dict) -> list[str]:
    out = [
        f"### {name}",
        "",
        f"`{s['shm']}`: magic `{s['magic_text']}` (`0x{s['magic']:016x}`), version {s['version']}, "
        f"header `{s['header']}`.",
        "",
        cell(s["meaning"]),
        "",
    ]
    for struct_name, st in s["structs"].items():
        out += [
            f"#### `{struct_name}` ({st['size']} bytes)",
            "",
            cell(st["meaning"]) + ".",
            "",
            "| offset | type | field | meaning |",
            "| ---: | --- | --- | --- |",
        ]
        end = 0
        for field_name, f in st["fields"].items():
            out.append(f"| {f['offset']} | {type_name(f)} | `{field_name}` | {cell(f['meaning'])} |")
            end = f["offset"] + f["size"]
        if end < st["size"]:
            pad = st["size"] - end
            out.append(f"| {end} | {pad} bytes | (padding) | to the struct's {st['align']}-byte alignment |")
        out.append("")
    if s["constants"]:
        out += ["| constant | value | meaning |", "| --- | ---: | --- |"]
        out += [f"| `{k}` | {c['value']} | {cell(c['meaning'])} |" for k, c in s["constants"].items()]
        out.append("")
    for enum_name, e in s["enums"].items():
        out += [f"`{enum_name}` ({cell(e['meaning'])}):", "", "| value | name | meaning |", "| ---: | --- | --- |"]
        out += [f"| {v['value']} | `{k}` | {cell(v['meaning'])} |" for k, v in e["values"].items()]
        out.append("")
    return out


def doc_section(description: dict) -> str:
    lines = [DOC_BEGIN, ""]
    for name, s in description["segments"].items():
        lines += segment_doc(name, s)
    return "\n".join(lines + [DOC_END])


def document(description: dict, text: str) -> str:
    if DOC_BEGIN not in text or DOC_END not in text:
        raise ValueError(f"{DOC} has lost its markers; put them back where the tables go:\n{DOC_BEGIN}\n{DOC_END}")
    head, rest = text.split(DOC_BEGIN, 1)
    _, tail = rest.split(DOC_END, 1)
    return head + doc_section(description) + tail


def outputs(irpd: Path) -> dict[Path, str]:
    text = subprocess.run([str(irpd), "--print-shm-layout"], check=True, capture_output=True, text=True).stdout
    return {DESCRIPTION: text, DOC: document(json.loads(text), DOC.read_text())}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--irpd", type=Path, default=ROOT / "build" / "bin" / "irpd", help="the irpd to ask")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 naming the stale files")
    args = parser.parse_args()
    try:
        files = outputs(args.irpd)
    except (OSError, ValueError, subprocess.CalledProcessError) as e:
        print(f"generate.py: {e}", file=sys.stderr)
        return 2
    return write_or_check(files, args.check, COMMAND, ROOT)


if __name__ == "__main__":
    sys.exit(main())
