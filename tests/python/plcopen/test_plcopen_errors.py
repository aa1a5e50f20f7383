# test_plcopen_errors.py -- what `stc check` says about a PLCopen XML file, as a user runs it: an error
# in a drawn body names the POU, the body's language, the rung and the element's localId (item 2);
# bad input (item 6) is refused with a clear error: not XML, another namespace or version, an element
# the schema does not know (named), a connection to a missing localId, a file over the size limit, an
# entity-expansion bomb, IL it cannot translate, a jump with no label after it.

from __future__ import annotations

import json

import plcopen_xml as x
import pytest
from plcopen_live import run_stc


def check(tmp_path, data: bytes, name: str = "plc.xml") -> list[dict]:
    (tmp_path / name).write_bytes(data)
    r = run_stc(["check", "--json", name], tmp_path)
    assert r.returncode == 1, r.stdout + r.stderr
    return json.loads(r.stdout)


def one(tmp_path, data: bytes) -> dict:
    errors = check(tmp_path, data)
    assert len(errors) == 1, errors
    return errors[0]


def ladder(body: str, *variables: str) -> bytes:
    iface = x.section("localVars", *variables) if variables else ""
    return x.project(x.pou("main", "program", iface, "LD", body))


def test_an_undeclared_contact_variable_names_pou_rung_and_element(tmp_path):
    body = x.rail(1) + x.contact(17, "Start", 1, 100, 0) + x.coil(18, "Motor", 17, 300, 0)
    body += x.contact(27, "Motor", 1, 100, 100) + x.coil(28, "Lamp", 27, 300, 100)
    err = one(tmp_path, ladder(body, x.var("Motor", "BOOL"), x.var("Lamp", "BOOL")))
    assert err["origin"] == "main (LD) rung 1, contact localId 17"
    assert err["message"].startswith("'Start' is not declared")
    r = run_stc(["check", "plc.xml"], tmp_path)
    assert "plc.xml:" in r.stderr and "main (LD) rung 1, contact localId 17: 'Start' is not declared" in r.stderr


def test_the_rung_is_counted_in_evaluation_order(tmp_path):
    body = x.rail(1) + x.contact(5, "A", 1, 100, 0) + x.coil(6, "B", 5, 300, 0)
    body += x.contact(7, "A", 1, 100, 100) + x.coil(8, "Nope", 7, 300, 100)
    err = one(tmp_path, ladder(body, x.var("A", "BOOL"), x.var("B", "BOOL")))
    assert err["origin"] == "main (LD) rung 2, coil localId 8"


def test_a_type_error_in_a_drawn_rung_names_the_element(tmp_path):
    body = x.rail(1) + x.contact(3, "n", 1, 100, 0) + x.coil(4, "b", 3, 300, 0)
    err = one(tmp_path, ladder(body, x.var("n", "INT"), x.var("b", "BOOL")))
    assert err["origin"].startswith("main (LD) rung 1, ")
    assert err["code"] == "type"


def test_a_connection_to_a_missing_local_id(tmp_path):
    body = x.rail(1) + x.contact(3, "a", 99, 100, 0) + x.coil(4, "a", 3, 300, 0)
    err = one(tmp_path, ladder(body, x.var("a", "BOOL")))
    assert err["origin"] == "main (LD) rung 1, contact localId 3"
    assert "a connection to localId 99, which no element has" in err["message"]


def test_a_jump_needs_a_label_after_it(tmp_path):
    body = x.rail(1) + x.label(2, "BACK", 0, 0) + x.contact(3, "a", 1, 100, 100) + x.jump(4, "BACK", 3, 300, 100)
    err = one(tmp_path, ladder(body, x.var("a", "BOOL")))
    assert "the jump to 'BACK' finds no label after it" in err["message"]
    assert err["origin"] == "main (LD) rung 1, jump localId 4"


def test_not_xml(tmp_path):
    err = one(tmp_path, b"<project><pou></project>")
    assert err["code"] == "xml" and "not well-formed XML" in err["message"]


@pytest.mark.parametrize(
    "namespace, says",
    [
        ("http://www.plcopen.org/xml/tc6_0200", "it is TC6 XML 2.0"),
        ("http://www.plcopen.org/xml/tc6.xsd", "it is TC6 XML 1.0"),
        ("urn:something-else", "a PLCopen XML 2.01 file is a <project>"),
    ],
)
def test_another_namespace_or_version(tmp_path, namespace, says):
    data = ladder("").replace(b"http://www.plcopen.org/xml/tc6_0201", namespace.encode())
    err = one(tmp_path, data)
    assert "not a PLCopen XML 2.01 file" in err["message"] and says in err["message"]


def test_an_unknown_element_is_refused_by_name(tmp_path):
    body = x.rail(1) + '<relay localId="2"><position x="0" y="0"/></relay>'
    errors = check(tmp_path, ladder(body))
    assert any("relay" in e["message"] for e in errors), errors
    assert all(e["code"] == "plcopen" for e in errors)


def test_a_file_over_the_size_limit(tmp_path):
    data = ladder("").replace(b"</project>", b"<!--" + b"x" * (50 << 20) + b"--></project>")
    err = one(tmp_path, data)
    assert err["code"] == "too-large" and "split the project" in err["message"]


def test_an_entity_expansion_bomb_is_not_expanded(tmp_path):
    bomb = b'<?xml version="1.0"?>\n<!DOCTYPE project [\n<!ENTITY a "aaaaaaaaaa">\n'
    bomb += b"".join(b'<!ENTITY %s "%s">\n' % (b"a" * (i + 2), (b"&" + b"a" * (i + 1) + b";") * 10) for i in range(9))
    bomb += b"]>\n" + ladder("").split(b"?>", 1)[1].replace(b'name="test"', b'name="&aaaaaaaaaa;"')
    err = one(tmp_path, bomb)
    assert "DTD" in err["message"] and "entities are not expanded" in err["message"]


def test_il_it_cannot_translate_names_the_line(tmp_path):
    il = '<IL><xhtml:p><![CDATA[LD a\nAND( b\nOR c\n)\nST a\n]]></xhtml:p></IL>'
    iface = x.section("localVars", *(x.var(v, "BOOL") for v in "abc"))
    data = x.project(f'<pou name="main" pouType="program"><interface>{iface}</interface><body>{il}</body></pou>')
    err = one(tmp_path, data)
    assert err["origin"] == "main (IL) line 2"
    assert "'AND(' (a parenthesised operator) is not supported" in err["message"]
