#!/usr/bin/env python3
# fuzz_st.py -- atheris (libFuzzer for Python) target for stc, the Structured Text compiler (st/):
# arbitrary bytes as one .st source through what `stc check` does: the size, NUL and UTF-8 checks,
# comments, lark's parser, the tree, and check() with the standard library.
# Expected: a checked program, or a StError / StErrors whose messages are not empty; any other
# exception (IndexError, RecursionError, lark's own errors, ...) is a finding.  Run by tests/fuzz/run.sh
# with libFuzzer's options, e.g.
#   .venv/bin/python tests/fuzz/fuzz_st.py -max_total_time=60 tests/fuzz/corpus/fuzz_st
import os
import sys

import atheris

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "st"))

with atheris.instrument_imports():
    from stc_compiler.check import check
    from stc_compiler.errors import StError, StErrors
    from stc_compiler.parse import decode, parse_text

# The standard library's tree is parsed once per input by check(); keep inputs small enough that an
# input takes well under libFuzzer's -timeout.
MAX_INPUT = 64 << 10


def test_one_input(data: bytes) -> None:
    data = data[:MAX_INPUT]
    try:
        check([parse_text("fuzz.st", decode("fuzz.st", data))])
    except StErrors as e:
        if not e.errors or any(not err.message.strip() for err in e.errors):
            raise AssertionError("an StErrors with an empty message") from e
    except StError as e:
        if not e.message.strip():
            raise AssertionError("a StError without a message") from e


def main() -> None:
    atheris.Setup(sys.argv, test_one_input)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
