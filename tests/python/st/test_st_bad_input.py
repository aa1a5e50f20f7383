# test_st_bad_input.py -- inputs that must give one clear error, never a traceback: a source over the size
# limit, NUL bytes, bytes that are not UTF-8, nesting deeper than the limit, an unclosed comment, and
# the same through the stc executable (exit 1, the error on stderr, no "Traceback").

from __future__ import annotations

from st_helpers import errors_of, run_stc
from stc_compiler.parse import MAX_DEPTH, MAX_SOURCE_BYTES, decode


def only(errors):
    assert len(errors) == 1, errors
    return errors[0]


def test_source_over_the_size_limit(write, tmp_path):
    path = write("big.st", b"(*" + b"x" * (10 << 20) + b"*)")
    result = run_stc(["check", str(path)], tmp_path)
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert result.stderr.strip() == (
        f"{path}:1:1: error[too-large]: the file has {(10 << 20) + 4} bytes, more than the limit of "
        f"{MAX_SOURCE_BYTES} bytes; split it into several files"
    )


def test_nul_byte():
    e = only([_decode_error("main.st", b"PROGRAM P\n  x\0 := 1;\nEND_PROGRAM\n")])
    assert (e.line, e.col, e.code) == (2, 4, "encoding")
    assert e.message == "a NUL byte; a source file is text: remove it"


def test_invalid_utf8(write, tmp_path):
    path = write("bad.st", b"PROGRAM P\n  (* caf\xe9 *)\nEND_PROGRAM\n")
    result = run_stc(["check", str(path)], tmp_path)
    assert result.returncode == 1
    assert result.stderr.strip() == f"{path}:2:9: error[encoding]: bytes that are not UTF-8; save the file as UTF-8"


def test_expression_nested_too_deep():
    text = "PROGRAM P VAR x : INT; END_VAR\nx := " + "-" * (MAX_DEPTH + 50) + "1;\nEND_PROGRAM\n"
    e = only(errors_of(text))
    assert (e.line, e.code) == (2, "too-deep")
    assert (
        e.message == f"nested deeper than {MAX_DEPTH} levels; split the expression or the statements into smaller ones"
    )


def test_statements_nested_too_deep():
    n = MAX_DEPTH
    text = "PROGRAM P VAR x : BOOL; END_VAR\n" + "IF x THEN\n" * n + "END_IF;\n" * n + "END_PROGRAM\n"
    assert only(errors_of(text)).code == "too-deep"


def test_deep_but_allowed_nesting_checks_without_recursion_error():
    text = "PROGRAM P VAR x : INT; END_VAR\nx := " + "(" * 2000 + "1" + ")" * 2000 + " + 1" * 150 + ";\nEND_PROGRAM\n"
    from st_helpers import compile_st

    compile_st({"main.st": text})


def test_unclosed_comment():
    e = only(errors_of("PROGRAM P\n(* (* nested *)\nEND_PROGRAM\n"))
    assert (e.line, e.col, e.code) == (2, 1, "syntax")
    assert e.message == "the comment '(*' is never closed; close it with '*)'"


def test_comment_closer_without_opener():
    e = only(errors_of("PROGRAM P\n *)\nEND_PROGRAM\n"))
    assert (e.line, e.col) == (2, 2) and e.message == "'*)' closes no comment; remove it or open one with '(*'"


def test_empty_file_is_clean(write, tmp_path):
    result = run_stc(["check", str(write("empty.st", ""))], tmp_path)
    assert result.returncode == 0, result.stderr


def test_binary_garbage_gives_an_error_not_a_traceback(write, tmp_path):
    path = write("junk.st", bytes(range(1, 256)) * 4)
    result = run_stc(["check", str(path)], tmp_path)
    assert result.returncode == 1 and "Traceback" not in result.stderr and "error[" in result.stderr


def _decode_error(name, data):
    from stc_compiler.errors import StError

    try:
        decode(name, data)
    except StError as e:
        return e
    raise AssertionError("no error")
