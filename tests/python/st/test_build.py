# test_build.py -- `stc build` without running anything: the module.xml entries of the tasks (period,
# priority, the overrun watchdog), a hand-written module.xml's other modules kept, the default task of
# a source without CONFIGURATION, RETAIN/PERSISTENT passed to glbc, a set rebuilt in place, the C++ in
# --cpp-dir, and every standard function of stdlib.py's table compiling against the runtime.

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

from live_processes import ROOT
from st_live import stc_build

TASKS = """
PROGRAM Fast VAR n : INT; END_VAR n := n + 1; END_PROGRAM
PROGRAM Slow VAR RETAIN kept : DINT; END_VAR VAR PERSISTENT recipe : REAL; END_VAR kept := kept + 1; END_PROGRAM
CONFIGURATION Plant
  VAR_GLOBAL shared : INT; END_VAR
  RESOURCE Cpu ON PLC
    TASK T1 (INTERVAL := T#2ms, PRIORITY := 0);
    TASK T2 (INTERVAL := T#100ms, PRIORITY := 5);
    PROGRAM Quick WITH T1 : Fast;
    PROGRAM Lazy WITH T2 : Slow;
  END_RESOURCE
END_CONFIGURATION
"""


def modules(path) -> dict:
    root = ET.parse(path).getroot()
    return {m.findtext("filename"): {c.tag: c.text for c in m} for m in root.iter("module")}


def test_tasks_become_module_xml_entries(tmp_path):
    r = stc_build(tmp_path, {"plant.st": TASKS}, "--no-compile")
    assert r.returncode == 0, r.stdout
    mods = modules(tmp_path / "set" / "module.xml")
    assert mods["./Quick.so"]["period"] == "2000000" and mods["./Quick.so"]["priority"] == "0"
    assert mods["./Lazy.so"]["period"] == "100000000" and mods["./Lazy.so"]["priority"] == "5"
    assert mods["./Quick.so"]["on_overrun"] == "disable" and mods["./Quick.so"]["overrun_limit"] == "4000000"
    assert (tmp_path / "set" / "Quick.cpp").is_file() and (tmp_path / "set" / "Lazy.cpp").is_file()
    doc = json.loads((tmp_path / "set" / "layout.json").read_text())
    qualifiers = {v["path"]: v.get("retain") for v in doc["variables"]}
    assert qualifiers["Lazy.kept"] == "retain" and qualifiers["Lazy.recipe"] == "persistent"
    assert qualifiers["Quick.n"] is None and "Plant.shared" in qualifiers


def test_a_hand_written_module_xml_keeps_its_other_modules(tmp_path):
    hand = tmp_path / "hand"
    hand.mkdir()
    (hand / "module.xml").write_text(
        "<root>\n  <!-- the drive -->\n  <module><filename>./drive.so</filename><moduletype>thread</moduletype>"
        "<operationtype>periodic</operationtype><period>1000000</period><priority>2</priority></module>\n"
        "  <module><filename>./Quick.so</filename><moduletype>thread</moduletype>"
        "<operationtype>periodic</operationtype><period>5</period><priority>9</priority></module>\n</root>\n"
    )
    r = stc_build(tmp_path, {"plant.st": TASKS}, "--no-compile", "--module-xml", str(hand / "module.xml"))
    assert r.returncode == 0, r.stdout
    mods = modules(tmp_path / "set" / "module.xml")
    assert list(mods) == ["./../hand/drive.so", "./Quick.so", "./Lazy.so"]
    assert mods["./Quick.so"]["period"] == "2000000"  # the CONFIGURATION's, not the hand-written entry's
    assert "the drive" in (tmp_path / "set" / "module.xml").read_text()


def test_without_configuration_each_program_runs_on_the_default_task(tmp_path):
    r = stc_build(
        tmp_path, {"p.st": "PROGRAM Blink VAR lit : BOOL; END_VAR lit := NOT lit; END_PROGRAM\n"}, "--no-compile"
    )
    assert r.returncode == 0, r.stdout
    mods = modules(tmp_path / "set" / "module.xml")
    assert mods["./Blink.so"]["period"] == "10000000" and mods["./Blink.so"]["priority"] == "10"


def test_errors_as_json_and_exit_codes(tmp_path):
    r = stc_build(tmp_path, {"p.st": "PROGRAM P VAR x : INT; END_VAR x := TRUE; END_PROGRAM\n"}, "--no-compile")
    assert r.returncode == 1
    [e] = json.loads(r.stdout)
    assert (e["file"], e["line"], e["code"]) == ("p.st", 1, "type") and "BOOL" in e["message"]
    r = stc_build(tmp_path, {"p.st": "PROGRAM P END_PROGRAM\n"}, "--bogus")
    assert r.returncode == 2


def standard_calls() -> str:
    """A program that calls every standard function of stdlib.py's table except the conversions,
    and one conversion of each spelling (the table's C++ names are generated, not listed twice)."""
    import sys

    sys.path.insert(0, str(ROOT / "st"))
    from stc_compiler import stdlib

    args = {"ANY_REAL": "r", "ANY_NUM": "r", "ANY_INT": "i", "ANY_BIT": "w", "ANY_MAGNITUDE": "i", "STRING": "s"}
    args |= {"ANY": "i", "ANY_ELEMENTARY": "i", "BOOL": "b", "INT": "i"}
    lines = []
    for fn in stdlib.FUNCTIONS.values():
        if fn.kind in ("conversion", "intrinsic"):
            continue
        params = [args.get(p.family if p.type == "T" else p.type, "i") for p in fn.params]
        if fn.name in ("SHL", "SHR", "ROL", "ROR", "AND", "OR", "XOR", "NOT"):
            params = ["w"] * len(params) if fn.name not in ("SHL", "SHR", "ROL", "ROR") else ["w", "i"]
        if fn.name == "MUX":
            params = ["i", "i", "i"]
        if fn.name == "MOD":
            params = ["i", "i"]
        if fn.name in ("EXPT",):
            params = ["r", "i"]
        target = {"BOOL": "b", "INT": "i", "STRING": "s", "DINT": "d"}.get(fn.result, None)
        if target is None:
            target = {"r": "r", "w": "w", "s": "s"}.get(params[1] if fn.name in ("SEL",) else params[0], "i")
        lines.append(f"  {target} := {fn.name}({', '.join(params)});")
    conversions = [
        "d := TIME_TO_DINT(t);",
        "t := DINT_TO_TIME(d);",
        "tod1 := DT_TO_TOD(dt1);",
        "tod1 := DATE_AND_TIME_TO_TIME_OF_DAY(dt1);",
        "d := TO_DINT(r);",
        "i := REAL_TRUNC_INT(r);",
        "d := TRUNC(r);",
        "s := INT_TO_STRING(i);",
        "i := STRING_TO_INT(s);",
        "ld := DATE_TO_LDATE(dd);",
        "dd := LDATE_TO_DATE(ld);",
        "r := LREAL_TO_REAL(lr);",
        "lr := TO_LREAL(i);",
        "w := INT_TO_WORD(i);",
        "b := WORD_TO_BOOL(w);",
        "lti := TIME_TO_LTIME(t);",
        "d := LTOD_TO_DINT(ltod1);",
    ]
    lines += [f"  {c}" for c in conversions]
    decls = (
        "VAR r : REAL := 2.0; lr : LREAL; i : INT := 1; d : DINT; w : WORD := 3; b : BOOL; s : STRING := 'ab'; "
        "t : TIME; lti : LTIME; tod1 : TOD; dt1 : DT; dd : DATE; ld : LDATE; ltod1 : LTOD; END_VAR\n"
    )
    return "PROGRAM Std\n" + decls + "\n".join(lines) + "\nEND_PROGRAM\n"


def test_every_standard_function_compiles_against_the_runtime(tmp_path):
    r = stc_build(tmp_path, {"std.st": standard_calls()})
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "set" / "Std.so").is_file()


def test_a_compile_error_of_the_generated_code_is_an_internal_error_at_the_st_line():
    import sys

    sys.path.insert(0, str(ROOT / "st"))
    from stc_compiler.sdk import internal_errors

    stderr = "main.st:12:9: error: no matching function for call to 'ADD(short int&, bool)'\nmore text\n"
    [e] = internal_errors(stderr, "out/Main.cpp")
    assert (e.file, e.line, e.col, e.code) == ("main.st", 12, 9, "internal")
    assert "error of stc" in e.message and "out/Main.cpp" in e.message


def test_an_installed_sdk_prefix(tmp_path):
    """--sdk PREFIX with the installed layout (include/indurop with st/, lib/libindurop.so), as the
    .deb puts it under /usr and the agent compiles against it."""
    from st_live import BUILD

    prefix = tmp_path / "prefix"
    include = prefix / "include" / "indurop"  # as installed: the SDK's headers, the runtime's in st/
    include.mkdir(parents=True)
    for item in (ROOT / "rtcore" / "include" / "indurop").iterdir():
        (include / item.name).symlink_to(item)
    (include / "st").symlink_to(ROOT / "st" / "runtime" / "include" / "indurop" / "st")
    (prefix / "lib").mkdir()
    (prefix / "lib" / "libindurop.so").symlink_to(BUILD / "rtcore" / "libindurop.so")
    program = {"p.st": "PROGRAM P VAR n : INT; END_VAR n := n + 1; END_PROGRAM\n"}
    r = stc_build(tmp_path, program, "--sdk", str(prefix))  # the last --sdk given wins
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "set" / "P.so").is_file()
    r = stc_build(tmp_path, program, "--sdk", str(tmp_path / "nothing"))
    assert r.returncode == 1 and json.loads(r.stdout)[0]["code"] == "sdk"


def test_an_at_binding_needs_the_sets_layout(tmp_path):
    program = {"p.st": "PROGRAM P VAR go AT %IO.start : INT; END_VAR go := 1; END_PROGRAM\n"}
    r = stc_build(tmp_path, program, "--no-compile")
    assert r.returncode == 1
    [e] = json.loads(r.stdout)
    assert e["code"] == "binding" and "--glb" in e["message"] and e["line"] == 1


def test_a_set_rebuilt_in_place(tmp_path):
    """OUT is the set's folder: its layout.json and module.xml, written by the last build, are given
    again as --set-layout and --module-xml; the ST namespaces in them are the program's own."""
    program = {"p.st": TASKS}
    assert stc_build(tmp_path, program, "--no-compile").returncode == 0
    out = tmp_path / "set"
    first = (out / "module.xml").read_text()
    again = ("--no-compile", "--set-layout", str(out / "layout.json"), "--module-xml", str(out / "module.xml"))
    for _ in range(2):
        r = stc_build(tmp_path, program, *again)
        assert r.returncode == 0, r.stdout
        assert list(modules(out / "module.xml")) == ["./Quick.so", "./Lazy.so"]
        # the same sources rebuilt: the same module.xml (stc's note in it once), so the same set
        assert (out / "module.xml").read_text() == first


def test_the_generated_cpp_goes_to_cpp_dir_outside_the_set(tmp_path):
    r = stc_build(tmp_path, {"p.st": TASKS}, "--no-compile", "--cpp-dir", str(tmp_path / "cpp"))
    assert r.returncode == 0, r.stdout
    assert sorted(p.name for p in (tmp_path / "cpp").iterdir()) == ["Lazy.cpp", "Quick.cpp"]
    assert not list((tmp_path / "set").glob("*.cpp"))
    assert (tmp_path / "set" / "module.xml").is_file() and (tmp_path / "set" / "indurop" / "generated.h").is_file()
