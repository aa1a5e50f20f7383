# test_language.py -- the .glb forms glbc accepts (docs/glbc.md), beyond the paper's figures: lax
# terminators, lines that continue an unfinished declaration, comments, #define forms, several
# files and namespaces, and how each shows in layout.json and the header.

from __future__ import annotations

from glb_helpers import load_layout


def ok(glb, files, *extra, order=None):
    result = glb(files, *extra, order=order)
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    return load_layout(glb.out)


def header(glb) -> str:
    return (glb.out / "indurop" / "generated.h").read_text()


def variables(doc):
    return [(v["path"], v["type"], v["dims"]) for v in doc["variables"]]


def test_declaration_ends_at_end_of_file_without_newline(glb):
    doc = ok(glb, {"a.glb": "namespace a\nint x"})
    assert variables(doc) == [("a.x", "int", [])]


def test_semicolons_and_line_ends_mix(glb):
    doc = ok(glb, {"a.glb": "namespace a;\nint x; int y\nint z;;\n;\n"})
    assert [v[0] for v in variables(doc)] == ["a.x", "a.y", "a.z"]


def test_unfinished_declaration_continues_on_the_next_line(glb):
    doc = ok(glb, {"a.glb": "namespace a;\nunsigned\n  long\n  x\nint y[\n 3\n]\n"})
    assert variables(doc) == [("a.x", "unsigned long", []), ("a.y", "int", [3])]


def test_struct_brace_on_the_next_line_and_last_field_without_semicolon(glb):
    doc = ok(glb, {"a.glb": "namespace a;\nstruct\n\n{ double x; double y } p\nstruct { int a } q;\n"})
    assert doc["types"]["a.p_t"]["size"] == 16 and doc["types"]["a.q_t"]["size"] == 4


def test_block_comments_inside_a_line_and_across_lines(glb):
    doc = ok(glb, {"a.glb": "namespace a;\nshort /* inline */ I0 /* two\n lines */ short I1\n"})
    assert [v[0] for v in variables(doc)] == ["a.I0", "a.I1"]


def test_crlf_line_ends_and_byte_order_mark(glb):
    doc = ok(glb, {"a.glb": "\ufeffnamespace a;\r\nshort I0 // c\r\nshort I1\r\n".encode("utf-8")})
    assert [v[0] for v in variables(doc)] == ["a.I0", "a.I1"]


def test_namespace_with_double_colons(glb):
    doc = ok(glb, {"a.glb": "namespace knu::Robot;\nint x;\n"})
    assert doc["namespaces"] == ["knu.Robot"]
    assert "namespace knu::Robot {" in header(glb)


def test_define_forms(glb):
    doc = ok(glb, {"a.glb": "#define A 0x10\nnamespace a;\n#define B 6u\n#define C -1\nint x[A][B]\n"})
    assert doc["defines"] == {"a.A": 16, "a.B": 6, "a.C": -1}
    assert variables(doc) == [("a.x", "int", [16, 6])]
    h = header(glb)
    assert "inline constexpr long A = 16;" in h and "inline constexpr long C = -1;" in h
    assert "#define A" not in h


def test_define_visible_in_a_later_file_of_the_same_namespace(glb):
    doc = ok(glb, {"a.glb": "namespace a;\n#define N 4\n", "b.glb": "namespace a;\nint x[N];\n"})
    assert variables(doc) == [("a.x", "int", [4])]


def test_define_inside_a_struct_is_namespace_wide(glb):
    doc = ok(glb, {"a.glb": "namespace a;\nstruct {\n  #define N 2\n  int v[N];\n} s;\nint w[N];\n"})
    assert doc["defines"] == {"a.N": 2} and variables(doc)[1] == ("a.w", "int", [2])


def test_same_name_in_two_namespaces(glb):
    doc = ok(glb, {"a.glb": "namespace a;\nint x;\n#define N 1\n", "b.glb": "namespace b;\ndouble x;\n#define N 2\n"})
    assert variables(doc) == [("a.x", "int", []), ("b.x", "double", [])]
    assert doc["defines"] == {"a.N": 1, "b.N": 2}


def test_namespace_and_a_nested_namespace(glb):
    doc = ok(glb, {"a.glb": "namespace a;\nint x;\n", "b.glb": "namespace a.b;\nint x;\n"})
    assert doc["namespaces"] == ["a", "a.b"]


def test_several_files_share_a_namespace_in_command_line_order(glb):
    doc = ok(
        glb, {"b.glb": "namespace n;\nint second;\n", "a.glb": "namespace n;\nint first;\n"}, order=["a.glb", "b.glb"]
    )
    assert [(v["name"], v["lock"], v["source"]) for v in doc["variables"]] == [
        ("first", 0, "a.glb:2"),
        ("second", 1, "b.glb:2"),
    ]
    assert header(glb).count("namespace n {") == 2  # one block per file


def test_empty_and_comment_only_files_contribute_nothing(glb):
    doc = ok(glb, {"empty.glb": "", "comments.glb": "// nothing\n/* here */\n\n", "a.glb": "namespace a;\nint x;\n"})
    assert doc["sources"] == ["empty.glb", "comments.glb", "a.glb"] and doc["lock_count"] == 1


def test_only_empty_files_give_an_empty_segment(glb):
    doc = ok(glb, {"empty.glb": ""})
    assert (doc["data_size"], doc["lock_count"], doc["variables"], doc["leaves"]) == (0, 0, [], [])
    assert "#define INDUROP_LAYOUT_LOCK_COUNT 0u" in header(glb)


def test_all_type_spellings(glb):
    spellings = {
        "int8_t": "int8_t",
        "uint64_t": "uint64_t",
        "char": "char",
        "signed char": "signed char",
        "unsigned char": "unsigned char",
        "short": "short",
        "short int": "short",
        "signed short int": "short",
        "unsigned short": "unsigned short",
        "int": "int",
        "signed": "int",
        "unsigned": "unsigned int",
        "unsigned int": "unsigned int",
        "long": "long",
        "long int": "long",
        "unsigned long": "unsigned long",
        "long unsigned int": "unsigned long",
        "long long": "long long",
        "unsigned long long": "unsigned long long",
        "float": "float",
        "double": "double",
        "bool": "bool",
        "BOOL": "bool",
    }
    text = "namespace t;\n" + "".join(f"{w} v{i};\n" for i, w in enumerate(spellings))
    doc = ok(glb, {"t.glb": text})
    assert [v["type"] for v in doc["variables"]] == list(spellings.values())
    assert doc["scalars"]["unsigned long"] == {"size": 8, "align": 8, "kind": "unsigned"}
    assert doc["scalars"]["bool"] == {"size": 1, "align": 1, "kind": "bool"}


def test_header_shapes(glb):
    ok(glb, {"a.glb": "namespace k.r;\nint t;\nint m[2][3];\nstruct { struct { int a; } f[4]; double g; } v[5];\n"})
    h = header(glb)
    assert "inline constexpr ::irp::shared::ScalarRef<int> t{0, 0};" in h
    assert (
        "inline constexpr ::irp::shared::ArrayRef<::irp::shared::ArrayRef<::irp::shared::ScalarRef<int>, 3>, 2> "
        "m{64, 1};"
    ) in h
    assert "inline constexpr ::irp::shared::ArrayRef<v_t_ref, 5> v{128, 2};" in h
    assert "struct v_t_f_t {" in h and "struct v_t_f_t_ref : ::irp::shared::StructRef<v_t_f_t> {" in h
    assert "    v_t_f_t f[4];" in h and "    ::irp::shared::ArrayRef<v_t_f_t_ref, 4> f;" in h
    assert "          f(offset + 0, lock, true)," in h and "          g(offset + 16, lock, true) {}" in h
    assert 'static_assert(sizeof(v_t[5]) == 120 && alignof(v_t) == 8, "glbc layout of k.r.v");' in h
    assert h.index("struct v_t_f_t {") < h.index("struct v_t {")  # nested types first


def test_a_file_without_namespace_declares_global_variables(glb):
    # The paper's Figures 7 and 8 use `joint[0].x` and the path "joint[1].y" without a namespace.
    doc = ok(glb, {"joint.glb": "// joint.glb\n#define N 4\nstruct { double x; double y; double z; } joint[N]\n"})
    assert variables(doc) == [("joint", "joint_t", [4])]
    assert doc["defines"] == {"N": 4}
    assert any(leaf["path"] == "joint[1].y" for leaf in doc["leaves"])
    text = header(glb)
    assert "(global namespace)" in text and "inline constexpr ::irp::shared::ArrayRef<joint_t_ref, 4> joint{" in text


def test_global_and_namespaced_files_together(glb):
    doc = ok(
        glb, {"a.glb": "namespace knu.Robot;\nuint32_t tick;\n", "b.glb": "uint32_t tick;\n"}, order=["a.glb", "b.glb"]
    )
    assert [v[0] for v in variables(doc)] == ["knu.Robot.tick", "tick"]
