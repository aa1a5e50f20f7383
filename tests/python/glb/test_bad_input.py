# test_bad_input.py -- one named test per malformed .glb input: glbc exits 1, writes nothing, and
# prints `file:line:col: error: ...` with the exact wording, the source line and a caret under
# the column.

from __future__ import annotations

NS = "namespace a;\n"
GUTTER = len("    2 | ")


def check(result, first_line: str, out=None):
    assert result.returncode == 1, f"exit {result.returncode}, stderr:\n{result.stderr}"
    lines = result.stderr.splitlines()
    assert lines[0] == first_line, result.stderr
    if out is not None:
        assert not out.exists(), "glbc wrote outputs despite an error"
    return lines


def check_caret(lines, source_line: str, col: int):
    """The excerpt: the source line after the gutter, and the caret under column `col`."""
    assert lines[1].endswith(" | " + source_line), lines
    assert lines[2].index("^") == GUTTER + col - 1, lines


# -- types and names ------------------------------------------------------------------------------


def test_unknown_type(glb):
    lines = check(
        glb({"a.glb": NS + "uint33_t x;\n"}),
        "a.glb:2:1: error: unknown type 'uint33_t': expected a scalar type (int8_t … uint64_t, char, short, "
        "int, long, unsigned …, float, double, bool, BOOL) or 'struct'",
        glb.out,
    )
    check_caret(lines, "uint33_t x;", 1)


def test_unsupported_long_double(glb):
    check(
        glb({"a.glb": NS + "long double x;\n"}),
        "a.glb:2:1: error: unsupported type 'long double': expected a scalar type (int8_t … uint64_t, char, short, "
        "int, long, unsigned …, float, double, bool, BOOL) or 'struct'",
    )


def test_invalid_type_combination(glb):
    check(
        glb({"a.glb": NS + "short long x;\n"}),
        "a.glb:2:1: error: invalid type 'short long': expected a scalar type (int8_t … uint64_t, char, short, "
        "int, long, unsigned …, float, double, bool, BOOL) or 'struct'",
    )


def test_duplicate_name_in_one_file(glb):
    lines = check(
        glb({"a.glb": NS + "int x;\nstruct {\n  int y;\n} x;\n"}),
        "a.glb:5:3: error: duplicate name 'x' in namespace a: first declared at a.glb:2:5",
        glb.out,
    )
    check_caret(lines, "} x;", 3)
    assert lines[3] == "a.glb:2:5: note: variable 'x' is declared here"


def test_duplicate_name_across_two_files_of_one_namespace(glb):
    lines = check(
        glb({"a.glb": NS + "int x;\n", "b.glb": "// b\nnamespace a;\ndouble x;\n"}),
        "b.glb:3:8: error: duplicate name 'x' in namespace a: first declared at a.glb:2:5",
        glb.out,
    )
    assert lines[3] == "a.glb:2:5: note: variable 'x' is declared here"


def test_duplicate_define_and_variable(glb):
    check(
        glb({"a.glb": NS + "#define N 3\nint N;\n"}),
        "a.glb:3:5: error: duplicate name 'N' in namespace a: first declared at a.glb:2:9",
    )


def test_duplicate_field(glb):
    check(
        glb({"a.glb": NS + "struct {\n  int a;\n  double a;\n} x;\n"}),
        "a.glb:4:10: error: duplicate field 'a' in the struct of variable 'x': first declared at a.glb:3:7",
    )


def test_name_clashes_with_generated_struct_type(glb):
    check(
        glb({"a.glb": NS + "struct { int a; } x;\nint x_t;\n"}),
        "a.glb:3:5: error: variable 'x_t' clashes with the struct type 'x_t' that glbc generates for variable 'x' "
        "at a.glb:2:19; rename one of them",
    )


def test_generated_struct_type_clashes_with_earlier_name(glb):
    check(
        glb({"a.glb": NS + "int x_t_ref;\nstruct { int a; } x;\n"}),
        "a.glb:3:19: error: the struct type 'x_t_ref' that glbc generates for variable 'x' clashes with "
        "variable 'x_t_ref' at a.glb:2:5; rename one of them",
    )


def test_field_name_clashes_with_generated_struct_type(glb):
    check(
        glb({"a.glb": NS + "struct {\n  struct { int b; } inner;\n  int x_t_inner_t;\n} x;\n"}),
        "a.glb:4:7: error: field 'x_t_inner_t' clashes with the struct type 'x_t_inner_t' that glbc generates for "
        "field 'inner' of x_t at a.glb:3:21; rename one of them",
    )


def test_name_clashes_with_a_namespace(glb):
    check(
        glb({"a.glb": NS + "int b;\n", "ab.glb": "namespace a.b;\nint c;\n"}),
        "a.glb:2:5: error: variable 'b' of namespace a clashes with namespace a.b (declared at ab.glb:1:11): "
        "both would be a::b in C++",
    )


def test_bad_identifier(glb):
    lines = check(
        glb({"a.glb": NS + "int 9lives;\n"}),
        "a.glb:2:5: error: expected a variable name after the type, found '9lives' "
        "(a name starts with a letter or '_')",
    )
    check_caret(lines, "int 9lives;", 5)


def test_bad_namespace_part(glb):
    check(
        glb({"a.glb": "namespace knu.9Robot;\n"}),
        "a.glb:1:15: error: expected a namespace name part, found '9Robot' (a name starts with a letter or '_')",
    )


def test_keyword_as_name(glb):
    check(
        glb({"a.glb": NS + "int class;\n"}), "a.glb:2:5: error: 'class' is a C++ keyword and cannot be used as a name"
    )


def test_keyword_as_field_name(glb):
    check(
        glb({"a.glb": NS + "struct {\n  double delete;\n} x;\n"}),
        "a.glb:3:10: error: 'delete' is a C++ keyword and cannot be used as a name",
    )


def test_keyword_as_namespace(glb):
    check(
        glb({"a.glb": "namespace knu.template;\n"}),
        "a.glb:1:15: error: 'template' is a C++ keyword and cannot be used as a name",
    )


def test_type_name_as_name(glb):
    check(
        glb({"a.glb": NS + "double uint32_t;\n"}),
        "a.glb:2:8: error: 'uint32_t' is a type name and cannot be used as a name",
    )


def test_reserved_identifier(glb):
    check(
        glb({"a.glb": NS + "int __x;\n"}),
        "a.glb:2:5: error: '__x' is reserved in C++ (names containing '__' or starting with '_' and a capital letter)",
    )


def test_reserved_field_name(glb):
    check(
        glb({"a.glb": NS + "struct { int value_type; } x;\n"}),
        "a.glb:2:14: error: 'value_type' is reserved as a field name (the generated reference class uses it)",
    )


def test_named_struct(glb):
    check(
        glb({"a.glb": NS + "struct Foo { int a; } x;\n"}),
        "a.glb:2:8: error: expected '{' after 'struct', found 'Foo' (structs in .glb are anonymous: "
        "`struct { … } name;`)",
    )


def test_empty_struct(glb):
    check(glb({"a.glb": NS + "struct { } x;\n"}), "a.glb:2:1: error: a struct needs at least one field")


# -- array sizes ----------------------------------------------------------------------------------


def test_array_size_zero(glb):
    lines = check(glb({"a.glb": NS + "int x[0];\n"}), "a.glb:2:7: error: array size must be at least 1, found 0")
    check_caret(lines, "int x[0];", 7)


def test_array_size_negative(glb):
    check(glb({"a.glb": NS + "int x[-3];\n"}), "a.glb:2:7: error: array size must be at least 1, found -3")


def test_array_size_not_an_integer(glb):
    check(glb({"a.glb": NS + "int x[1.5];\n"}), "a.glb:2:7: error: expected an integer array size, found '1.5'")


def test_array_size_octal(glb):
    check(
        glb({"a.glb": NS + "int x[010];\n"}),
        "a.glb:2:7: error: '010' would be octal in C, which .glb does not accept: write the array size in decimal",
    )


def test_array_size_missing(glb):
    check(glb({"a.glb": NS + "int x[];\n"}), "a.glb:2:7: error: expected the size of array 'x' between '[' and ']'")


def test_array_size_too_large(glb):
    check(
        glb({"a.glb": NS + "int x[16777217];\n"}),
        "a.glb:2:7: error: array size 16777217 is too large (at most 16777216)",
    )


def test_array_size_undefined_define(glb):
    check(
        glb({"a.glb": NS + "int x[N];\n"}),
        "a.glb:2:7: error: 'N' is not a #define of namespace a declared before this line: "
        "an array size is an integer or a #define name",
    )


def test_array_size_define_of_another_namespace(glb):
    check(
        glb({"a.glb": NS + "#define N 4\n", "b.glb": "namespace b;\nint x[N];\n"}),
        "b.glb:2:7: error: 'N' is not a #define of namespace b declared before this line: "
        "an array size is an integer or a #define name",
    )


def test_array_size_define_used_before_it_is_defined(glb):
    check(
        glb({"a.glb": NS + "int x[N];\n#define N 4\n"}),
        "a.glb:2:7: error: 'N' is not a #define of namespace a declared before this line: "
        "an array size is an integer or a #define name",
    )


def test_array_size_define_of_zero(glb):
    check(
        glb({"a.glb": NS + "#define N 0\nint x[N];\n"}),
        "a.glb:3:7: error: array size must be at least 1, found 0 (#define N)",
    )


def test_define_with_semicolon(glb):
    check(
        glb({"a.glb": NS + "#define N 6;\n"}),
        "a.glb:2:12: error: expected end of line after '#define N 6' (a #define takes one integer and no ';'), "
        "found ';'",
    )


def test_define_without_value(glb):
    check(
        glb({"a.glb": NS + "#define N\nint x;\n"}),
        "a.glb:2:10: error: expected an integer value for #define N, found end of line",
    )


def test_other_directive(glb):
    check(
        glb({"a.glb": "#include <x>\n" + NS}),
        "a.glb:1:2: error: '#include' is not supported: a .glb file knows only #define",
    )


# -- limits ---------------------------------------------------------------------------------------


def test_segment_over_max_size(glb):
    lines = check(
        glb({"a.glb": NS + "uint8_t small[100];\ndouble b[16777216];\n"}),
        "a.glb:3:8: error: segment over its limit: variable 'b' (134217728 bytes at offset 128) ends at "
        "byte 134217856, over --max-size 16777216",
        glb.out,
    )
    check_caret(lines, "double b[16777216];", 8)


def test_segment_over_a_given_max_size(glb):
    check(
        glb({"a.glb": NS + "int x;\nint y;\n"}, "--max-size", "100"),
        "a.glb:3:5: error: segment over its limit: variable 'y' (4 bytes at offset 64) ends at byte 128, "
        "over --max-size 100",
    )


def test_too_many_leaves(glb):
    check(
        glb({"a.glb": NS + "uint8_t small[10];\nuint8_t buf[199991];\n"}),
        "a.glb:3:9: error: too many scalars: variable 'buf' brings layout.json's leaves to 200001, "
        "over the limit of 200000",
    )


def test_largest_dimension_passes_the_size_check_but_not_the_leaf_limit(glb):
    check(
        glb({"a.glb": NS + "uint8_t b[16777216];\n"}, "--max-size", "32M"),
        "a.glb:2:9: error: too many scalars: variable 'b' brings layout.json's leaves to 16777216, "
        "over the limit of 200000",
    )


# -- structure ------------------------------------------------------------------------------------


def test_missing_closing_brace(glb):
    lines = check(
        glb({"a.glb": NS + "struct {\n  int a;\n  int b;\n"}),
        "a.glb:4:9: error: expected '}' to close the struct opened at line 2, found end of file",
    )
    check_caret(lines, "  int b;", 9)
    assert lines[3] == "a.glb:2:8: note: the struct opens here"


def test_missing_name_after_brace(glb):
    lines = check(
        glb({"a.glb": NS + "struct {\n  int a;\n};\n"}),
        "a.glb:4:2: error: expected the variable's name after '}' (on the same line), found ';'",
    )
    check_caret(lines, "};", 2)


def test_missing_name_after_brace_at_end_of_line(glb):
    check(
        glb({"a.glb": NS + "struct {\n  int a;\n} // comment\nint b;\n"}),
        "a.glb:4:2: error: expected the variable's name after '}' (on the same line), found end of line",
    )


def test_namespace_after_global_declarations(glb):
    lines = check(
        glb({"a.glb": "// global first\nuint32_t tick;\nnamespace a;\n"}),
        "a.glb:3:1: error: 'namespace' after global declarations: a file's declarations are either all "
        "global or all in its one namespace, declared before them",
    )
    check_caret(lines, "namespace a;", 1)


def test_second_namespace_line(glb):
    lines = check(
        glb({"a.glb": NS + "int x;\nnamespace b;\n"}),
        "a.glb:3:1: error: a second namespace line: this file already declared namespace a; "
        "put each namespace in its own .glb file",
    )
    assert lines[3] == "a.glb:1:11: note: namespace a declared here"


def test_two_declarations_on_one_line_without_semicolon(glb):
    lines = check(
        glb({"a.glb": NS + "short I0 short I1\n"}),
        "a.glb:2:10: error: expected ';' or end of line after 'I0', found 'short'",
    )
    check_caret(lines, "short I0 short I1", 10)


def test_comma_separated_names(glb):
    check(glb({"a.glb": NS + "double x, y;\n"}), "a.glb:2:9: error: expected ';' or end of line after 'x', found ','")


def test_initial_value(glb):
    check(glb({"a.glb": NS + "int x = 5;\n"}), "a.glb:2:7: error: expected ';' or end of line after 'x', found '='")


def test_stray_closing_brace(glb):
    check(glb({"a.glb": NS + "int x;\n}\n"}), "a.glb:3:1: error: expected a declaration (a type and a name), found '}'")


# -- characters and files -------------------------------------------------------------------------


def test_unterminated_block_comment(glb):
    lines = check(
        glb({"a.glb": NS + "int x; /* open\n  never closed\n"}),
        "a.glb:2:8: error: unterminated /* comment: expected '*/' before the end of the file",
    )
    check_caret(lines, "int x; /* open", 8)


def test_garbage_character(glb):
    lines = check(
        glb({"a.glb": NS + "int x @;\n"}),
        "a.glb:2:7: error: unexpected character '@': expected a declaration, a comment or a #define",
    )
    check_caret(lines, "int x @;", 7)


def test_non_ascii_in_a_name(glb):
    check(
        glb({"a.glb": NS + "int café;\n"}),
        "a.glb:2:8: error: unexpected character 'é': expected a declaration, a comment or a #define",
    )


def test_invalid_utf8(glb):
    check(
        glb({"a.glb": NS.encode() + b"// caf\xe9\n"}),
        "a.glb:2:7: error: invalid UTF-8 (byte 0xe9): a .glb file is UTF-8 text",
    )


def test_caret_under_a_tab_indented_column(glb):
    lines = check(glb({"a.glb": NS + "\tint\tx[0];\n"}), "a.glb:2:8: error: array size must be at least 1, found 0")
    assert lines[2] == "      | \t   \t  ^"


def test_file_not_found(glb):
    result = glb({}, order=["missing.glb"])
    check(result, "missing.glb: error: cannot read file: No such file or directory", glb.out)


def test_error_in_second_file_writes_nothing(glb):
    check(
        glb({"a.glb": NS + "int x;\n", "b.glb": "namespace b;\nfoo y;\n"}),
        "b.glb:2:1: error: unknown type 'foo': expected a scalar type (int8_t … uint64_t, char, short, int, long, "
        "unsigned …, float, double, bool, BOOL) or 'struct'",
        glb.out,
    )


def test_structs_nested_too_deep(glb):
    text = NS + "struct {\n" * 33 + "int a;\n" + "} s;\n" * 33
    check(glb({"a.glb": text}), "a.glb:34:1: error: structs nest more than 32 deep")


def test_structs_nested_32_deep_are_fine(glb):
    text = NS + "struct {\n" * 32 + "int a;\n" + "} s;\n" * 32
    result = glb({"a.glb": text})
    assert result.returncode == 0, result.stderr
