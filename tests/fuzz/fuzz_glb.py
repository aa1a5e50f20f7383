#!/usr/bin/env python3
# fuzz_glb.py -- atheris (libFuzzer for Python) target for glbc, the .glb compiler (glb/): arbitrary
# bytes as one to three .glb files (split at NUL bytes) through what `glbc A.glb B.glb -o DIR`
# does short of writing: UTF-8 decoding, lexer, parser, layout, layout.json and generated.h.
# Expected: the outputs, or a GlbError whose diagnostic formats; any other exception (IndexError,
# RecursionError, ...) is a finding.  Run by tests/fuzz/run.sh with libFuzzer's options, e.g.
#   .venv/bin/python tests/fuzz/fuzz_glb.py -max_total_time=60 tests/fuzz/corpus/fuzz_glb
import os
import sys

import atheris

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "glb"))

with atheris.instrument_imports():
    from glbc_compiler.cli import source
    from glbc_compiler.emit_header import render as render_header
    from glbc_compiler.emit_layout import document
    from glbc_compiler.emit_layout import render as render_layout
    from glbc_compiler.errors import GlbError
    from glbc_compiler.layout import build
    from glbc_compiler.parser import parse_file

MAX_SIZE = 1 << 20  # a smaller data area than glbc's default keeps each input quick


def test_one_input(data: bytes) -> None:
    files = data.split(b"\0", 2)
    try:
        parsed = [parse_file(source(f"f{i}.glb", text)) for i, text in enumerate(files)]
        layout = build(parsed, MAX_SIZE)
        doc = document(layout)
        render_header(layout, doc["hash"], ["fuzz"])
        render_layout(layout)
    except GlbError as e:
        message = e.format()
        if not message.strip():
            raise AssertionError("a GlbError without a message") from e


def main() -> None:
    atheris.Setup(sys.argv, test_one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
