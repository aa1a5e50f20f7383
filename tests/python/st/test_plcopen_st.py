# test_plcopen_st.py -- st/lib/plcopen.st: the PLCopen motion blocks and the alarm functions are
# callable from ST with their PLCopen signatures, refuse parameters the C++ blocks lack, and each
# block's ST fields are the C++ struct's bytes (a C++ compile of offsetof/sizeof static_asserts).

from __future__ import annotations

import shutil
import subprocess

import pytest
from st_helpers import ROOT, compile_st, errors_of, one_error
from stc_compiler import types as ty

CELL = """
PROGRAM P
VAR
  Robot : AXES_GROUP_REF;
  Power : MC_Power; Home : MC_Home; MoveJ : MC_MoveAbsolute; MoveL : MC_MoveLinear;
  MoveR : MC_MoveRelative; Jog : MC_MoveVelocity; Halt : MC_Stop; Reset : MC_Reset;
  Pos : MC_ReadActualPosition; Status : MC_ReadStatus; AxisErr : MC_ReadAxisError;
  GroupErr : MC_GroupReadError;
  target : AXES := [0.0, -0.5, 1.0, 0.0, 0.5, 0.0];
  done : BOOL; id : DINT; ok : BOOL;
END_VAR
Power(AxesGroup := Robot, Enable := TRUE);
Home(AxesGroup := Robot, Execute := Power.Status, Position := target, Velocity := 0.5, Acceleration := 0.5);
MoveJ(AxesGroup := Robot, Execute := Home.Done, Position := target, Velocity := 0.5, Done => done);
MoveL(AxesGroup := Robot, Execute := done, Position := target, Velocity := 0.25, Acceleration := 0.5);
MoveR(AxesGroup := Robot, Execute := FALSE, Distance := target);
Jog(AxesGroup := Robot, Execute := FALSE, Velocity := target, Acceleration := 1.0);
Halt(AxesGroup := Robot, Execute := FALSE);
Reset(AxesGroup := Robot, Execute := FALSE);
Pos(AxesGroup := Robot, Enable := TRUE);
Status(AxesGroup := Robot, Enable := TRUE);
AxisErr(AxesGroup := Robot, Enable := TRUE, AxisErrorID => id);
GroupErr(AxesGroup := Robot, Enable := TRUE);
Robot.Service.dTarget[2] := Pos.Position[2] + 0.1;
IF GroupErr.GroupErrorID <> 0 THEN
  ok := RaiseAlarm(id := 8, detail := 'robot in error', value := DINT_TO_LREAL(GroupErr.GroupErrorID));
ELSE
  ClearAlarm(8);
END_IF;
ok := RaiseAlarm(id := 9, detail := '', value := 0.0, severity := AlarmHigh);
END_PROGRAM
"""


def test_the_blocks_take_their_plcopen_parameters():
    prog = compile_st({"main.st": CELL})
    assert prog.pous["MC_MOVEABSOLUTE"].extern == "plcopen::MC_MoveAbsolute"
    assert prog.types["AXES_GROUP_REF"].extern == "plcopen::bindAxisGroup"
    assert prog.pous["RAISEALARM"].extern == "irp::raiseAlarm"


@pytest.mark.parametrize("param, value", [("Deceleration", "0.5"), ("Jerk", "1.0"), ("BufferMode", "1")])
def test_parameters_the_cpp_blocks_lack_are_refused_by_name(param, value):
    text = CELL.replace("Velocity := 0.5, Done => done", f"Velocity := 0.5, {param} := {value}, Done => done")
    e = one_error(text)
    assert e.code == "parameter"
    assert f"MC_MoveAbsolute has no parameter '{param}'" in e.message
    assert "plcopen::MC_MoveAbsolute" in e.message and "remove it" in e.message


def test_the_axes_group_must_be_given():
    e = one_error(CELL.replace("Halt(AxesGroup := Robot, Execute := FALSE)", "Halt(Execute := FALSE)"))
    assert "AxesGroup" in e.message and e.code == "parameter"


def test_an_extern_block_has_no_body():
    e = one_error(
        "{extern 'plcopen::Y'}\nFUNCTION_BLOCK Y\nVAR_INPUT a : BOOL; END_VAR\nVAR b : BOOL; END_VAR\nb := a;\nEND_FUNCTION_BLOCK\n"
    )
    assert e.code == "declaration" and (e.place.line, e.place.col) == (5, 1)
    assert "implemented in C++ (plcopen::Y)" in e.message


def test_a_misplaced_or_malformed_extern_pragma_is_named():
    e = one_error("PROGRAM P\nVAR a : BOOL; END_VAR\n{extern 'plcopen::Y'}\na := TRUE;\nEND_PROGRAM\n")
    assert (e.place.line, e.place.col) == (3, 1) and "must stand right before" in e.message
    e = one_error("{extern x::Y}\nFUNCTION_BLOCK Y\nEND_FUNCTION_BLOCK\n")
    assert "{extern 'namespace::Name'}" in e.message
    # other pragmas (other compilers' attributes) are still ignored
    compile_st({"a.st": "{attribute 'hide'}\nFUNCTION_BLOCK Y\nVAR_INPUT a : BOOL; END_VAR\nEND_FUNCTION_BLOCK\n"})


def test_an_extern_names_a_library_the_modules_link():
    e = one_error("{extern 'std::Thing'}\nFUNCTION_BLOCK Y\nVAR_INPUT a : BOOL; END_VAR\nEND_FUNCTION_BLOCK\n")
    assert "no C++ library the modules link has 'std::Thing'" in e.message and "plcopen::" in e.message


def test_an_extern_type_is_a_struct():
    errs = errors_of("{extern 'plcopen::f'}\nTYPE T : INT; END_TYPE\n")
    assert any("binds a STRUCT type" in e.message for e in errs)


# ---- the layout: an ST instance is the C++ struct's bytes ---------------------------------------

_SIZE = {
    "bool": 1,
    "int8_t": 1,
    "uint8_t": 1,
    "int16_t": 2,
    "uint16_t": 2,
    "int32_t": 4,
    "uint32_t": 4,
    "int64_t": 8,
    "uint64_t": 8,
    "float": 4,
    "double": 8,
}


def _layout(typ) -> tuple[int, int, list[tuple[str, int]]]:
    """(size, alignment, [(member path, offset)]) of an ST type laid out as C/C++ (and glbc) do."""
    typ = ty.base(typ)
    if isinstance(typ, ty.Elementary):
        return _SIZE[typ.cpp], _SIZE[typ.cpp], []
    if isinstance(typ, ty.ArrayType):
        size, align, _ = _layout(typ.element)
        count = 1
        for lo, hi in typ.dims:
            count *= hi - lo + 1
        return size * count, align, []
    members = (
        typ.members.values()
        if isinstance(typ, ty.StructType)
        else [v for v in typ.pou.vars if v.kind in ("VAR_INPUT", "VAR_OUTPUT", "VAR")]
    )
    offset, align, fields = 0, 1, []
    for m in members:
        size, a, inner = _layout(m.type)
        offset = (offset + a - 1) // a * a
        fields.append((m.name, offset))
        fields += [(f"{m.name}.{path}", offset + off) for path, off in inner]
        offset += size
        align = max(align, a)
    return (offset + align - 1) // align * align, align, fields


@pytest.mark.skipif(shutil.which("g++") is None, reason="needs g++")
def test_every_extern_block_is_laid_out_as_its_cpp_struct(tmp_path):
    prog = compile_st({"main.st": CELL})
    lines = ["#include <indurop/plcopen/plcopen.h>", "#include <cstddef>"]
    blocks = [p for p in prog.pous.values() if p.extern and p.kind == "FUNCTION_BLOCK"]
    assert len(blocks) == 12
    for pou in blocks:
        size, _, fields = _layout(ty.FbType(pou))
        lines.append(f"static_assert(sizeof({pou.extern}) == {size}, \"{pou.name}: size\");")
        for path, off in fields:
            lines.append(f"static_assert(offsetof({pou.extern}, {path}) == {off}, \"{pou.name}.{path}\");")
    status = prog.types["GROUP_STATUS"].type
    size, _, fields = _layout(status)
    lines.append(f"static_assert(sizeof(plcopen::GroupStatus) == {size});")
    lines += [f"static_assert(offsetof(plcopen::GroupStatus, {p}) == {o});" for p, o in fields]
    src = tmp_path / "layout.cpp"
    src.write_text("\n".join(lines) + "\n")
    include = ROOT / "rtcore" / "modules" / "plcopen" / "include"
    r = subprocess.run(
        ["g++", "-std=c++20", "-fsyntax-only", "-Wno-invalid-offsetof", f"-I{include}", str(src)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr


# ---- two groups: each block call reaches the group it names -------------------------------------

TWO_GROUPS = """
FUNCTION_BLOCK Cell  (* a group passed on through an FB's VAR_IN_OUT *)
VAR_IN_OUT G : AXES_GROUP_REF; END_VAR
VAR_INPUT enable : BOOL; END_VAR
VAR Power : MC_Power; END_VAR
  Power(AxesGroup := G, Enable := enable);
END_FUNCTION_BLOCK

PROGRAM Main
VAR
  A, B, C : AXES_GROUP_REF;
  PowerA, PowerB : MC_Power;
  CellC : Cell;
  onA, onB, onC : BOOL;
  runs : DINT;
END_VAR
  runs := runs + 1;
  PowerA(AxesGroup := A, Enable := onA);
  PowerB(AxesGroup := B, Enable := onB);
  CellC(G := C, enable := onC);
  PowerA(AxesGroup := A, Enable := onA);
END_PROGRAM
"""


def test_each_block_call_requests_from_the_group_it_is_given(tmp_path):
    """The C++ view of a group (plcopen::bindAxisGroup) is kept between calls: a call on another
    group, in the same run or through an FB, still writes its request into that group."""
    from live_processes import wait_until
    from st_live import Running

    run = Running(tmp_path, {"groups.st": TWO_GROUPS})
    try:
        wait_until(lambda: run.value("Main.runs") > 3)
        seqs = lambda: [run.value(f"Main.{g}.Service.nSeq") for g in "ABC"]  # noqa: E731
        assert seqs() == [0, 0, 0]
        for g, want in [("B", [0, 1, 0]), ("C", [0, 1, 1]), ("A", [1, 1, 1])]:
            run.client.request("write", path=f"Main.on{g}", value=True)
            wait_until(lambda g=g: run.value(f"Main.{g}.Service.nSeq") >= 1)
            assert [min(s, 1) for s in seqs()] == want, g
            assert run.value(f"Main.{g}.Service.eOpCode") == 1  # PowerOn
        assert run.value("Main.CellC.Power.Busy") and run.value("Main.PowerB.Busy")
    finally:
        run.close()
