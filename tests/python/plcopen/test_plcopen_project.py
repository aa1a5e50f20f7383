# test_plcopen_project.py -- what project.py makes of a project's declarations: data types (struct,
# array, enum, subrange, alias, string) with initial values (simple, array with repetition, struct),
# every variable list kind and its constant/retain/persistent flags, globals of the configuration and
# of the resource, tasks and their instances, an ST body; run in a real irpd, the initial values are
# read back.  A pouInstance bound to no task is refused; the graphical bodies' values (flows) are
# given to whoever asks (the live view).

from __future__ import annotations

import json

import plcopen_xml as x
from live_processes import wait_until
from plcopen_live import Running, run_stc, shared

TYPES = (
    '<dataType name="Pair"><baseType><struct>'
    + x.var("a", "INT", "3")
    + x.var("b", "<string length='8'/>")
    + "</struct></baseType></dataType>"
    '<dataType name="Color"><baseType><enum><values><value name="Red"/><value name="Green"/>'
    "</values></enum></baseType><initialValue><simpleValue value='Green'/></initialValue></dataType>"
    '<dataType name="Percent"><baseType><subrangeSigned><range lower="0" upper="100"/>'
    "<baseType><INT/></baseType></subrangeSigned></baseType></dataType>"
    '<dataType name="Flag"><baseType><BOOL/></baseType></dataType>'
    '<dataType name="Row"><baseType><array><dimension lower="1" upper="5"/>'
    "<baseType><DINT/></baseType></array></baseType></dataType>"
)
ARRAY_INIT = (
    "<initialValue><arrayValue><value><simpleValue value='7'/></value>"
    "<value repetitionValue='3'><simpleValue value='1'/></value></arrayValue></initialValue>"
)
STRUCT_INIT = (
    "<initialValue><structValue><value member='a'><simpleValue value='42'/></value>"
    "<value member='b'><simpleValue value=\"'hi'\"/></value></structValue></initialValue>"
)
ST = "<ST><xhtml:p><![CDATA[\nticks := ticks + 1;\npct := 50;\nEND_IF_NOT_A_KEYWORD := 0;\n]]></xhtml:p></ST>"


def interface() -> str:
    return (
        x.section("inputVars", x.var("go", "BOOL", "TRUE"))
        + x.section("outputVars", x.var("ticks", "DINT"))
        + x.section("localVars", x.var("pct", '<derived name="Percent"/>'), x.var("c", '<derived name="Color"/>'))
        + x.section("localVars", x.var("kept", "INT", "5"), retain="true")
        + x.section("localVars", x.var("LIMIT_", "INT", "9"), constant="true")
        + x.section("localVars", x.var("saved", "INT"), persistent="true")
        + x.section(
            "localVars",
            x.var("row", '<derived name="Row"/>').replace("</type>", "</type>" + ARRAY_INIT),
            x.var("p", '<derived name="Pair"/>').replace("</type>", "</type>" + STRUCT_INIT),
            x.var("f", '<derived name="Flag"/>', "TRUE"),
            x.var("END_IF_NOT_A_KEYWORD", "INT"),
        )
        + x.section("externalVars", x.var("shared", "INT"))
    )


def project(instances: str | None = None) -> bytes:
    pou = f'<pou name="Decls" pouType="program"><interface>{interface()}</interface><body>{ST}</body></pou>'
    conf = instances or (
        '<configuration name="Cfg"><resource name="Res">'
        '<task name="fast" priority="1" interval="T#10ms"><pouInstance name="inst" typeName="Decls"/></task>'
        + x.section("globalVars", x.var("local_global", "INT", "2"))
        + "</resource>"
        + x.section("globalVars", x.var("shared", "INT", "11"))
        + "</configuration>"
    )
    return x.project(pou, data_types=TYPES, instances=conf)


def test_declarations_run_with_their_initial_values(tmp_path):
    xml = tmp_path / "decls.xml"
    xml.write_bytes(project())
    run = Running(tmp_path, {"decls.xml": xml})
    try:
        wait_until(lambda: run.value("inst.ticks") > 2, 10)
        values = run.values("inst")
        assert list(run.values("inst.row").values()) == [7, 1, 1, 1, 0]
        assert run.value("inst.p.a") == 42 and run.string("inst.p.b") == "hi"
        assert run.value("inst.pct") == 50 and run.value("inst.kept") == 5 and run.value("inst.go") == 1
        assert run.value("inst.f") == 1
        assert "inst.LIMIT_" not in values  # a constant is not a variable
    finally:
        run.close()
    layout = json.loads((tmp_path / "set" / "layout.json").read_text())
    declared = {v["path"]: v for v in layout["variables"]}
    assert declared["inst.kept"]["retain"] == "retain" and declared["inst.saved"]["retain"] == "persistent"


def test_a_pou_instance_bound_to_no_task_is_refused(tmp_path):
    conf = (
        '<configuration name="Cfg"><resource name="Res"><task name="fast" priority="1" interval="T#10ms"/>'
        '<pouInstance name="loose" typeName="Decls"/></resource></configuration>'
    )
    (tmp_path / "p.xml").write_bytes(project(conf))
    r = run_stc(["check", "--json", "p.xml"], tmp_path)
    assert r.returncode == 1
    (err,) = json.loads(r.stdout)
    assert err["origin"] == "configuration Cfg, resource Res, pouInstance loose" and err["code"] == "task"
    assert "bound to no task" in err["message"]


def test_an_undeclared_type_names_the_variable(tmp_path):
    r = run_stc(["check", "--json", str(shared("beremiz_iec61131_lang_test"))], tmp_path)
    errors = json.loads(r.stdout)
    assert {e["origin"] for e in errors} >= {"main_test variable LOGGER0", "TEMPO_TEST variable RTC1"}


def test_flows_give_the_value_out_of_every_element():
    from plcopen_import.project import unit_of
    from plcopen_import.read import read_file
    from stc_compiler import tree as t

    path = str(shared("tutorial_xor_xnor"))
    flows: dict = {}
    unit_of(path, read_file(path), flows)
    # every contact's and coil's power, keyed by (body, localId, formal)
    assert {k[1] for k in flows} >= {3, 4, 5, 6, 7, 9, 10, 11, 12, 13}
    coil = flows[("XOR_and_XNOR", 7, None)]
    assert isinstance(coil, t.Binary) and coil.op == "OR"  # two branches into the coil
    assert flows[("XOR_and_XNOR", 3, None)].place.origin == "XOR_and_XNOR (LD) rung 1, contact localId 3"
