# test_plcopen_export.py -- the PLCopen XML 2.01 export (plcopen/plcopen_export, `stc export`): the cell's
# ST program exported validates against the TC6 schema and is read by an independent reader, the PyPI
# package `plcopen` (xsdata classes of the schema); ST bodies are the source text; expressions and
# declarations come back as the same tree; import -> export -> import gives the same tree for ST sources
# and for the shared real projects the importer takes (their drawings, positions included, kept);
# what PLCopen XML cannot say is refused naming the fix.

from __future__ import annotations

import subprocess
import sys

import pytest
from export_helpers import ROOT, STC, dump, independent_reader, interface_names
from plcopen_export import export, import_unit
from plcopen_export.st_print import expr
from plcopen_import import st_text
from plcopen_import.read import read
from plcopen_live import shared
from stc_compiler import tree as t
from stc_compiler.errors import StError, StErrors
from stc_compiler.parse import parse_file, parse_text

CELL_ST = ROOT / "config" / "sets" / "plc-robot-st" / "main.st"

EXPRESSIONS = """
TYPE
  Mode : (Off, Slow := 5, Fast);
  Small : INT (-10 .. 10);
  Pair : STRUCT a : SINT := 1; b : ARRAY[0..2, 1..2] OF REAL := [2(1.0), 4(0.5)]; END_STRUCT;
  Name : STRING[20] := 'cell';
END_TYPE
FUNCTION_BLOCK Fb
VAR_INPUT i : INT; END_VAR
VAR_OUTPUT q : BOOL; END_VAR
q := i > 0;
END_FUNCTION_BLOCK
PROGRAM P
VAR CONSTANT N : INT := 4; END_VAR
VAR RETAIN kept : ARRAY[0..N - 1] OF DINT := [1, 2, 3, 4]; END_VAR
VAR
  a, b, c : INT; r : REAL; x : BOOL; w : WORD := 16#FF; t1 : TIME := T#1s500ms;
  p : Pair := (a := 2, b := [6(0.0)]); m : Mode := Mode#Fast; f : Fb; ws : WSTRING;
  out AT %PLC_ROBOT.O0 : INT;
END_VAR
VAR_TEMP k : INT; END_VAR
a := (a + b) * c - -b;
a := a - (b - c);
r := 2.0 ** (3.0 ** 2.0);
r := (2.0 ** 3.0) ** 2.0;
x := NOT (x AND a > b) OR x XOR (a = b) AND NOT x;
x := (x OR x) AND x;
c := p.b[1, 2] > 0.5 AND w.3 OR kept[a MOD 4] = 1;
f(i := a, q => x);
f(i := ABS(-a), NOT q => x);
a := MAX(a, b, c);
x := AND(x, TRUE) OR (a <= b) = (b >= c);
END_PROGRAM
"""


def _export_text(text: str, name: str = "p.st") -> tuple[t.Unit, bytes]:
    unit = parse_text(name, text)
    return unit, export([unit], {name: text})


def test_cell_program_validates_and_is_read_by_the_plcopen_package():
    data = export([parse_file(str(CELL_ST))])
    read("cell.xml", data)  # the importer's reader: well-formed, the tc6_0201 namespace, the TC6 schema
    project = independent_reader(data)  # PyPI `plcopen` 1.0.1 (xsdata): unknown elements refused
    pous = {p.name: p for p in project.types.pous.pou}
    assert list(pous) == ["PickAndPlace", "Fault", "MoveOutcome"]
    assert [p.pou_type.value for p in pous.values()] == ["program", "function", "function"]
    source = parse_file(str(CELL_ST)).pous
    assert interface_names(pous["PickAndPlace"]) == sorted(d.name for d in source[0].vars)
    assert pous["MoveOutcome"].interface.return_type.bool_value is not None
    body = pous["PickAndPlace"].body[0].st.w3_org_1999_xhtml_element.text
    assert body.startswith("(* ---- start: the panel's defaults")  # the source's text, comments kept
    assert body.rstrip().endswith("  WaitingRaised := Waiting;\nEND_IF;")
    config = project.instances.configurations.configuration[0]
    assert config.name == "Cell" and config.resource[0].name == "Controller"
    task = config.resource[0].task[0]
    assert (task.name, task.interval, task.priority) == ("Plc", "T#10ms", 3)
    assert [(i.name, i.type_name) for i in task.pou_instance] == [("main", "PickAndPlace")]


def test_st_bodies_are_the_same_statements():
    """Each exported ST body, parsed again, is the statements of the source's POU."""
    source = parse_file(str(CELL_ST))
    root = read("cell.xml", export([source]))
    for pou, el in zip(source.pous, root.iter("{*}pou"), strict=True):
        text, line = st_text.text_of(el.find("{*}body/{*}ST"))
        assert dump(st_text.statements("cell.xml", text, line)) == dump(pou.body), pou.name


def test_declarations_and_expressions_come_back_as_written():
    """Every expression of the body, and every initial value and bound, printed by the export and read
    again by stc's parser, is the same tree; the types and lists are the schema's own elements."""
    unit, data = _export_text(EXPRESSIONS)
    read("p.xml", data)
    for stmt in unit.pous[1].body:
        e = stmt.value if isinstance(stmt, t.Assign) else stmt.call
        assert dump(st_text.expression("p.xml", expr(e), 1)) == dump(e), expr(e)
    project = independent_reader(data)
    types = {d.name: d.base_type for d in project.types.data_types.data_type}
    assert [v.name for v in types["Mode"].enum.values.value] == ["Off", "Slow", "Fast"]
    assert types["Small"].subrange_signed.range.lower == "-10"
    assert types["Name"].string.length == "20"
    pair = types["Pair"].struct.variable
    assert [d.lower + ".." + d.upper for d in pair[1].type.array.dimension] == ["0..2", "1..2"]
    assert [(v.repetition_value, v.simple_value.value) for v in pair[1].initial_value.array_value.value] == [
        ("2", "1.0"),
        ("4", "0.5"),
    ]
    p = next(p for p in project.types.pous.pou if p.name == "P")
    assert [(vl.constant, vl.retain) for vl in p.interface.local_vars][:2] == [(True, False), (False, True)]
    kept = p.interface.local_vars[1].variable[0]
    assert kept.type.array.dimension[0].upper == "N - 1"
    out = next(v for v in p.interface.local_vars[2].variable if v.name == "out")
    assert out.address == "%PLC_ROBOT.O0"
    init = {v.name: v.initial_value for v in p.interface.local_vars[2].variable if v.initial_value}
    assert [(v.member, bool(v.array_value)) for v in init["p"].struct_value.value] == [("a", False), ("b", True)]
    assert init["m"].simple_value.value == "Mode#Fast"


def test_what_plcopen_xml_cannot_say_is_refused_by_name():
    text = """
{extern 'cell::Gripper'}
FUNCTION_BLOCK Gripper
VAR_INPUT close : BOOL; END_VAR
END_FUNCTION_BLOCK
PROGRAM P
VAR_INPUT speed : INT; END_VAR
END_PROGRAM
CONFIGURATION C
  TASK T (INTERVAL := T#10ms, PRIORITY := 2);
  TASK U (INTERVAL := T#20ms, PRIORITY := LOW);
  PROGRAM p1 WITH T : P (speed := 3);
END_CONFIGURATION
"""
    with pytest.raises(StErrors) as e:
        _export_text(text)
    messages = [str(x) for x in e.value.errors]
    assert any("Gripper is implemented in C++" in m and m.startswith("p.st:3:1:") for m in messages), messages
    assert any("PROGRAM p1: a program instance's arguments" in m for m in messages), messages
    assert any("TASK U: PLCopen XML needs its PRIORITY as a number 0..65535" in m for m in messages), messages


def test_global_variables_outside_a_configuration_go_into_one():
    text = "VAR_GLOBAL Speed : INT := 3; END_VAR\nPROGRAM P\nVAR_EXTERNAL Speed : INT; END_VAR\nSpeed := Speed + 1;\nEND_PROGRAM\n"
    _, data = _export_text(text)
    (config,) = independent_reader(data).instances.configurations.configuration
    assert config.name == "Globals" and not config.resource
    assert [(v.name, v.initial_value.simple_value.value) for v in config.global_vars[0].variable] == [("Speed", "3")]


def test_stc_export_command(tmp_path):
    out = tmp_path / "cell.xml"
    done = subprocess.run(
        [sys.executable, str(STC), "export", "-o", str(out), "--name", "cell", str(CELL_ST)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert (done.returncode, done.stderr) == (0, "")
    assert independent_reader(out.read_bytes()).content_header.name == "cell"
    bad = tmp_path / "bad.st"
    bad.write_text("PROGRAM P\nVAR x : INT; END_VAR\nx := ;\nEND_PROGRAM\n")
    done = subprocess.run(
        [sys.executable, str(STC), "export", "-o", str(tmp_path / "bad.xml"), str(bad)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 1
    assert "bad.st:3:6: error[syntax]" in done.stderr
    assert not (tmp_path / "bad.xml").exists()


def test_an_invalid_name_is_an_error_not_a_file():
    with pytest.raises(StError):
        read("x.xml", b"<project/>")


SHARED_PROJECTS = [
    "beremiz4uc_traffic_lights",
    "beremiz_first_steps",
    "beremiz_iec61131_lang_test",
    "beremiz_python_datatypes",
    "openplc_blink",
    "openplc_multi_language",
    "openplc_traffic_light_fbd",
    "tutorial_not_or_nor",
    "tutorial_xor_xnor",
]


@pytest.mark.parametrize("name", SHARED_PROJECTS)
def test_a_shared_project_imported_exported_and_imported_again_is_the_same_tree(name):
    path = shared(name)
    try:
        first = import_unit(str(path))
    except (StError, StErrors) as e:
        pytest.skip(f"the importer does not take {name}: {str(e).splitlines()[0]}")
    data = export([first])
    independent_reader(data)  # the PyPI package `plcopen` reads it, every element known to it
    again = import_unit(f"{name}-exported.xml", data)
    assert dump(again) == dump(first)
    # the drawings are the file's, positions and all
    original = {p.get("name"): p for p in read(str(path), path.read_bytes()).iter("{*}pou")}
    for pou in read("exported.xml", data).iter("{*}pou"):
        for tag in ("body", "actions", "transitions"):
            mine = [_element(e) for e in pou.findall(f"{{*}}{tag}")]
            theirs = [_element(e) for e in original[pou.get("name")].findall(f"{{*}}{tag}")]
            assert mine == theirs, (pou.get("name"), tag)


def _element(el) -> tuple:
    """An element as (tag, attributes, text, children): layout whitespace and namespace declarations aside."""
    text = (el.text or "").strip() if len(el) else (el.text or "")
    return (el.tag, dict(el.attrib), text, [_element(c) for c in el if isinstance(c.tag, str)])


@pytest.mark.parametrize("which", ["declarations", "cell"])
def test_st_sources_exported_and_imported_are_the_same_tree(which):
    """The ST compiler's tree of ST sources, exported and imported, is the tree parsed from them; only
    a RESOURCE's ON name, which PLCopen XML has no place for, comes back as the importer's (PLC)."""
    unit = parse_text("p.st", EXPRESSIONS) if which == "declarations" else parse_file(str(CELL_ST))
    again = import_unit("exported.xml", export([unit], {"p.st": EXPRESSIONS}))
    for conf in unit.configurations:
        for r in conf.resources:
            r.on = "PLC"
    assert dump(again) == dump(unit)
