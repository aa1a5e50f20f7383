# test_previous.py -- glbc --previous: a layout laid out against the one that runs now.  Kept
# variables keep offset and lock, new and moved ones go first-fit into free space, holes and locks
# of removed variables persist through the lineage (at most 16 layouts), the changes and the
# summary line, every error about the previous file, and the layout stamp in generated.h.

from __future__ import annotations

import json
import re
import struct
import subprocess
from pathlib import Path

import pytest
from glb_helpers import RTCORE_INCLUDE, compile_case, load_layout, run_glbc

NS = "namespace a;\n"
GIVE = "give the layout.json that runs now (irpctl layout -o layout.json)"
OLDER = "written by an older glbc; compile the running set's .glb files again without --previous"
RESTART = "holes of removed variables count until the next irpd restart (then compile without --previous)"


def run(folder: Path, text: str, out: str, *extra: str) -> subprocess.CompletedProcess:
    """Writes a.glb (namespace a) and runs `glbc a.glb -o out EXTRA` in folder."""
    (folder / "a.glb").write_text(NS + text, encoding="utf-8")
    return run_glbc(["a.glb", "-o", out, *extra], folder)


def ok(folder: Path, text: str, out: str, previous: str | None = None, *extra: str) -> dict:
    """Compiles into folder/out, against folder/previous/layout.json when given; the layout.json."""
    result = run(folder, text, out, *(["--previous", f"{previous}/layout.json"] if previous else []), *extra)
    assert result.returncode == 0, result.stderr
    return load_layout(folder / out)


def placed(doc: dict) -> dict[str, tuple[int, int]]:
    return {v["name"]: (v["offset"], v["lock"]) for v in doc["variables"]}


def overlaps(doc: dict, start: int, end: int) -> list[str]:
    return [v["path"] for v in doc["variables"] if v["offset"] < end and start < v["offset"] + v["size"]]


# -- placement --------------------------------------------------------------------------------------

STRUCT = "struct { double d; int n[3]; } s[4];\n"


def test_unchanged_variables_keep_offset_and_lock(tmp_path):
    v1 = ok(tmp_path, "int x;\n" + STRUCT + "char c;\n", "v1")
    assert placed(v1) == {"x": (0, 0), "s": (64, 1), "c": (192, 2)}
    grown = "int first;\nint x;\n" + STRUCT + "int between;\nchar c;\n"
    v2 = ok(tmp_path, grown, "v2", "v1")
    assert placed(v2) == {"first": (256, 3), "x": (0, 0), "s": (64, 1), "between": (320, 4), "c": (192, 2)}
    assert (v2["data_size"], v2["lock_count"]) == (384, 5)
    assert placed(ok(tmp_path, grown, "fresh"))["x"] == (64, 1)  # without --previous everything shifts
    leaves = {leaf["path"]: (leaf["offset"], leaf["lock"]) for leaf in v2["leaves"]}
    assert leaves["a.first"] == (256, 3) and leaves["a.s[1].n[2]"] == (64 + 24 + 8 + 8, 1)
    assert [leaf["offset"] for leaf in v2["leaves"]] == [256, 0] + [leaf["offset"] for leaf in v1["leaves"][1:-1]] + [
        320,
        192,
    ]
    header = (tmp_path / "v2" / "indurop" / "generated.h").read_text()
    assert "ScalarRef<int> first{256, 3};" in header and "ScalarRef<int> x{0, 0};" in header
    assert "ArrayRef<s_t_ref, 4> s{64, 1};" in header and "// a.between: offset 320, 4 bytes, lock 4" in header


def test_new_variables_go_first_fit_into_free_space_in_declaration_order(tmp_path):
    v1 = ok(tmp_path, "int x;\nint y;\n", "v1")
    # A previous layout with free space: y at 512 with lock 5 leaves bytes 64..511 and locks 1..4 free.
    v1["variables"][1] |= {"offset": 512, "lock": 5}
    (tmp_path / "gap").mkdir()
    (tmp_path / "gap" / "layout.json").write_text(json.dumps(v1))
    v2 = ok(tmp_path, "int x;\nint y;\nchar big[300];\nchar small[100];\nchar tiny;\nchar huge[1000];\n", "v2", "gap")
    # big (5 cache lines) fits at 64, small (2) right after it; tiny and huge only after y.
    assert placed(v2) == {
        "x": (0, 0),
        "y": (512, 5),
        "big": (64, 1),
        "small": (384, 2),
        "tiny": (576, 3),
        "huge": (640, 4),
    }
    assert (v2["data_size"], v2["lock_count"]) == (1664, 6)


def test_a_removed_variable_leaves_a_hole_and_a_lock_that_are_not_reused(tmp_path):
    g1 = ok(tmp_path, "int x;\ndouble gone[20];\nint y;\n", "g1")
    assert placed(g1) == {"x": (0, 0), "gone": (64, 1), "y": (256, 2)}
    g2 = ok(tmp_path, "int x;\nint y;\n", "g2", "g1")
    assert placed(g2) == {"x": (0, 0), "y": (256, 2)}
    assert (g2["data_size"], g2["lock_count"]) == (320, 3)  # the hole's bytes and lock still count
    assert g2["changes"]["removed"] == ["a.gone"]
    g3 = ok(tmp_path, "int x;\nint y;\nint n1;\n", "g3", "g2")
    assert placed(g3)["n1"] == (320, 3)
    g4 = ok(tmp_path, "int x;\nint y;\nint n1;\nchar n2;\n", "g4", "g3")
    assert placed(g4) == {"x": (0, 0), "y": (256, 2), "n1": (320, 3), "n2": (384, 4)}
    assert (g4["data_size"], g4["lock_count"]) == (448, 5)
    for doc in (g3, g4):
        assert overlaps(doc, 64, 256) == [] and 1 not in [v["lock"] for v in doc["variables"]]
    assert [entry["hash"] for entry in g4["lineage"]] == [g3["hash"], g2["hash"], g1["hash"]]
    assert {"path": "a.gone", "type_id": g1["variables"][1]["type_id"], "offset": 64, "size": 160, "lock": 1} in g4[
        "lineage"
    ][2]["variables"]


@pytest.mark.parametrize(
    "before, after, kept",
    [
        ("int x;", "long x;", True),  # another scalar type, wider: converted
        ("int x;", "int x[2];", False),  # an array: not converted
        ("int x;", "unsigned x;", False),  # the same size, another meaning
        ("struct { int x; } x;", "struct { int y; } x;", True),  # a field name: x dropped, y new
        ("struct { int x; } x;", "struct { float x; } x;", False),  # int to float may lose values
    ],
)
def test_a_changed_type_is_moved_or_converted(tmp_path, before, after, kept):
    g1 = ok(tmp_path, before + "\nstruct { double a; } s;\n", "g1")
    g2 = ok(tmp_path, after + "\nstruct { double a; } s;\n", "g2", "g1")
    assert placed(g2) == {"x": (128, 2), "s": (64, 1)}
    changes = g2["changes"]
    assert (changes["added"], changes["removed"]) == ([], [])
    entry = (changes["converted"] if kept else changes["moved"])[0]
    assert {k: entry[k] for k in ("path", "from", "to")} == {"path": "a.x", "from": 0, "to": 128}
    assert len(changes["converted"] + changes["moved"]) == 1
    assert g2["variables"][0]["type_id"] != g1["variables"][0]["type_id"]
    g3 = ok(tmp_path, after + "\nstruct { double a; } s;\nchar c;\n", "g3", "g2")
    assert placed(g3)["c"] == (192, 3)  # not the old x's bytes nor its lock


def test_lineage_keeps_the_last_16_layouts_newest_first(tmp_path):
    ok(tmp_path, "int gone;\nint keep;\n", "g0")
    hashes = [load_layout(tmp_path / "g0")["hash"]]
    text = "int keep;\n"
    for k in range(1, 19):
        doc = ok(tmp_path, text, f"g{k}", f"g{k - 1}")
        assert [e["hash"] for e in doc["lineage"]] == hashes[::-1][:16]
        assert doc["changes"]["previous"] == hashes[-1]
        hashes.append(doc["hash"])
        if k >= 2:
            # gone's bytes (0..63) and lock 0 stay taken while g0 is in the previous layout's lineage
            # (through g16's, which holds g0 as its 16th entry); g18 may use them again.
            assert placed(doc)[f"v{k}"] == ((0, 0) if k == 18 else (64 * k, k))
        text += f"int v{k + 1};\n"


def test_changes_and_the_summary_line(tmp_path):
    g1 = ok(tmp_path, "int x;\nint gone;\nint s;\n", "g1")
    result = run(tmp_path, "long s;\nint x;\nint n;\n", "g2", "--previous", "g1/layout.json")
    assert result.returncode == 0, result.stderr
    assert result.stderr == f"glbc: against layout {g1['hash'][:12]}…: 1 added, 1 removed, 0 moved, 1 converted\n"
    g2 = load_layout(tmp_path / "g2")
    assert g2["changes"] == {
        "previous": g1["hash"],
        "added": ["a.n"],
        "removed": ["a.gone"],
        "moved": [],
        "converted": [
            {
                "path": "a.s",
                "from": 128,
                "to": 192,
                "from_type": "int",
                "to_type": "long",
                "dropped": [],
                "copies": [
                    {
                        "from": 128,
                        "to": 192,
                        "from_type": "s4",
                        "to_type": "s8",
                        "count": 1,
                        "from_stride": 0,
                        "to_stride": 0,
                    }
                ],
            }
        ],
    }
    assert list(g2)[:6] == ["format", "version", "hash", "data_size", "lock_count", "changes"]


def test_the_same_declarations_again_change_nothing(tmp_path):
    g1 = ok(tmp_path, "int x;\n" + STRUCT, "g1")
    result = run(tmp_path, "int x;\n" + STRUCT, "g2", "--previous", "g1/layout.json")
    assert result.stderr.endswith(": 0 added, 0 removed, 0 moved, 0 converted\n")
    g2 = load_layout(tmp_path / "g2")
    assert (g2["hash"], g2["data_size"], g2["lock_count"], g2["variables"], g2["leaves"]) == (
        g1["hash"],
        g1["data_size"],
        g1["lock_count"],
        g1["variables"],
        g1["leaves"],
    )
    assert g2["changes"] == {"previous": g1["hash"], "added": [], "removed": [], "moved": [], "converted": []}
    assert g2["lineage"] == [], "a layout is not its own ancestor"
    g3 = ok(tmp_path, "int x;\nint y;\n" + STRUCT, "g3", "g2")
    g4 = ok(tmp_path, "int x;\nint y;\n" + STRUCT, "g4", "g3")
    assert [e["hash"] for e in g4["lineage"]] == [g1["hash"]], "recompiling unchanged keeps the lineage as it was"
    assert g3["lineage"] == g4["lineage"]


def test_previous_may_be_the_output_itself(tmp_path):
    g1 = ok(tmp_path, "int x;\nint y;\n", "out")
    g2 = ok(tmp_path, "int y;\nint added;\n", "out", "out")
    assert placed(g2) == {"y": (64, 1), "added": (128, 2)}
    assert g2["changes"]["previous"] == g1["hash"] and g2["lineage"][0]["hash"] == g1["hash"]
    assert g2["changes"]["removed"] == ["a.x"]


def test_without_previous_there_are_no_changes_and_an_empty_lineage(tmp_path):
    out = compile_case("fig3", tmp_path)
    doc = load_layout(out)
    assert list(doc) == [
        "format",
        "version",
        "hash",
        "data_size",
        "lock_count",
        "sources",
        "namespaces",
        "defines",
        "scalars",
        "types",
        "variables",
        "leaves",
        "lineage",
    ]
    assert doc["lineage"] == [] and all(re.fullmatch(r"[0-9a-f]{16}", v["type_id"]) for v in doc["variables"])
    result = run(tmp_path, "int x;\n", "plain")
    assert result.returncode == 0 and result.stderr == ""


# -- errors -----------------------------------------------------------------------------------------


def good_previous(tmp_path: Path) -> dict:
    return ok(tmp_path, "int x;\nint y;\n", "v1")


def without(key: str, where: str = "variables"):
    def edit(doc):
        for v in doc[where] if where == "variables" else doc["lineage"][0]["variables"]:
            v.pop(key, None)
        return doc

    return edit


def old_glbc(doc):
    """What a layout.json from a glbc before --previous looks like: no type_id, no lineage."""
    doc.pop("lineage")
    for v in doc["variables"]:
        v.pop("type_id")
    return doc


def with_lineage(doc):
    doc["lineage"] = [{"hash": "0" * 64, "variables": [{"path": "a.old", "offset": 0, "size": 4, "lock": 0}]}]
    return doc


@pytest.mark.parametrize(
    "content, message",
    [
        (None, f"cannot read the previous layout: No such file or directory; {GIVE}"),
        ("folder", f"cannot read the previous layout: Is a directory; {GIVE}"),
        (b"{\"format\": ", f"the previous layout is not JSON (Expecting value: line 1 column 12 (char 11)); {GIVE}"),
        (b"\xff\xfe", None),  # not UTF-8: also "not JSON"
        (lambda doc: {"format": "something-else"}, f'not an indurop layout ("format" is not "indurop-layout"); {GIVE}'),
        (lambda doc: [doc], f'not an indurop layout ("format" is not "indurop-layout"); {GIVE}'),
        (
            lambda doc: doc | {"version": 2},
            "layout version 2; this glbc reads version 1: compile the running set's .glb "
            "files with the glbc that wrote it",
        ),
        (
            lambda doc: doc | {"hash": "abc"},
            f'the layout has no "hash" of 64 hex digits: not a layout glbc wrote; {GIVE}',
        ),
        (lambda doc: doc | {"variables": {}}, f'the layout has no "variables" list: not a layout glbc wrote; {GIVE}'),
        (without("path"), f'variable 0 of the layout has no "path": not a layout glbc wrote; {GIVE}'),
        (without("offset"), f'variable a.x of the layout has no valid "offset": not a layout glbc wrote; {GIVE}'),
        (without("size"), f'variable a.x of the layout has no valid "size": not a layout glbc wrote; {GIVE}'),
        (without("lock"), f'variable a.x of the layout has no valid "lock": not a layout glbc wrote; {GIVE}'),
        (without("type_id"), f'variable a.x of the layout has no "type_id": {OLDER}'),
        (old_glbc, f'variable a.x of the layout has no "type_id": {OLDER}'),
        (lambda doc: doc | {"lineage": {}}, f'"lineage" is not a list: not a layout glbc wrote; {GIVE}'),
        (with_lineage, f'variable a.old of lineage entry 0 has no "type_id": {OLDER}'),
    ],
)
def test_previous_errors(tmp_path, content, message):
    doc = good_previous(tmp_path)
    prev = tmp_path / "prev.json"
    if content == "folder":
        prev.mkdir()
    elif isinstance(content, bytes):
        prev.write_bytes(content)
    elif content is not None:
        prev.write_text(json.dumps(content(doc)))
    result = run(tmp_path, "int x;\nint y;\nint z;\n", "out", "--previous", "prev.json")
    assert result.returncode == 1, result.stderr
    assert len(result.stderr.splitlines()) == 1, result.stderr
    if message is None:
        assert result.stderr.startswith("prev.json: error: the previous layout is not JSON ("), result.stderr
    else:
        assert result.stderr == f"prev.json: error: {message}\n"
    assert not (tmp_path / "out").exists()


def test_max_size_counts_the_holes(tmp_path):
    ok(tmp_path, "int x;\nchar big[4000];\n", "g1")
    assert run(tmp_path, "int x;\nint n;\n", "fresh", "--max-size", "4K").returncode == 0
    result = run(tmp_path, "int x;\nint n;\n", "g2", "--previous", "g1/layout.json", "--max-size", "4K")
    assert result.returncode == 1
    assert result.stderr.splitlines()[0] == (
        "a.glb:3:5: error: segment over its limit: variable 'n' (4 bytes) goes to offset 4096, the first space the "
        f"running layout and its lineage leave free, and ends at byte 4160, over --max-size 4096; {RESTART}"
    )
    result = run(tmp_path, "int x;\n", "g2", "--previous", "g1/layout.json", "--max-size", "1K")
    assert result.returncode == 1
    assert result.stderr == (
        "g1/layout.json: error: segment over its limit: the variables and holes this layout keeps "
        f"end at byte 4096, over --max-size 1024; {RESTART}\n"
    )
    assert not (tmp_path / "g2").exists()


# -- the layout stamp in generated.h ----------------------------------------------------------------

STAMP = (
    'extern "C" __attribute__((weak, visibility("default"), section(".indurop_layout"))) '
    "const char indurop_layout_hash[] = INDUROP_LAYOUT_HASH;"
)


def test_the_stamp_is_in_its_own_section(tmp_path):
    ok(tmp_path, "int x;\n", "out")
    lines = (tmp_path / "out" / "indurop" / "generated.h").read_text().splitlines()
    assert STAMP in lines and lines[lines.index(STAMP) - 1].startswith("// Its own section: ")


def test_appending_a_variable_changes_only_the_stamp_in_the_header(tmp_path):
    text = "int x;\n" + STRUCT
    ok(tmp_path, text, "v1")
    ok(tmp_path, text + "double added[3];\n", "v2", "v1")
    h1, h2 = ((tmp_path / v / "indurop" / "generated.h").read_text().splitlines() for v in ("v1", "v2"))
    macros = (
        "#define INDUROP_LAYOUT_HASH ",
        "#define INDUROP_LAYOUT_DATA_SIZE ",
        "#define INDUROP_LAYOUT_LOCK_COUNT ",
        "// Regenerate: ",
    )
    assert all(line.startswith(macros) for line in set(h1) - set(h2))
    assert all(line.startswith(macros) or "added" in line for line in set(h2) - set(h1))


def alloc_sections(path: Path) -> dict[str, bytes]:
    """The contents of an ELF64 file's SHF_ALLOC sections (those loaded into memory), by name."""
    data = path.read_bytes()
    (shoff,) = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x3A)
    headers = [struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize) for i in range(shnum)]
    names = headers[shstrndx]
    out = {}
    for name, kind, flags, _, offset, size, *_ in headers:
        if flags & 2:  # SHF_ALLOC
            label = data[names[4] + name : data.index(b"\0", names[4] + name)].decode()
            out[label] = b"" if kind == 8 else data[offset : offset + size]  # SHT_NOBITS: no bytes in the file
    return out


def test_a_module_rebuilt_against_a_grown_layout_differs_only_in_the_stamp(cxx, tmp_path):
    text = "int x;\n" + STRUCT
    ok(tmp_path, text, "v1")
    ok(tmp_path, "int x;\nint before;\n" + STRUCT + "double added[3];\n", "v2", "v1")
    src = tmp_path / "module.cpp"
    src.write_text(
        "#include <indurop/generated.h>\n"
        'extern "C" int step() {\n'
        "    a::x += 1; a::s_t v = a::s[1]; v.n[2] = a::x; a::s[2] = v; return a::x;\n"
        "}\n"
    )
    built = {}
    for v in ("v1", "v2"):
        so = tmp_path / f"{v}.so"
        args = [cxx, "-std=c++20", "-O2", "-fPIC", "-shared", f"-I{tmp_path / v}", f"-I{RTCORE_INCLUDE}", str(src)]
        result = subprocess.run([*args, "-o", str(so)], capture_output=True, text=True, timeout=300)
        assert result.returncode == 0, result.stderr
        built[v] = alloc_sections(so)
    assert ".indurop_layout" in built["v1"] and built["v1"][".indurop_layout"] != built["v2"][".indurop_layout"]
    ignored = {".indurop_layout", ".note.gnu.build-id"}
    assert {k: x for k, x in built["v1"].items() if k not in ignored} == {
        k: x for k, x in built["v2"].items() if k not in ignored
    }
