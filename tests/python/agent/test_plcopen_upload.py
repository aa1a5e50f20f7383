"""test_plcopen_upload.py -- a PLCopen XML project (a real one drawn in OpenPLC Editor, read from
../shared/plcopen) uploaded to a real agent beside a real irpd: with irpctl it is imported and
compiled on the appliance like .st, stored as kind `plcopen`, activated and run, then changed
online with its values kept, while an .xml that is
not PLCopen (an ioconfig.xml) stays a config file; bad PLCopen input (an undeclared variable in a
rung, a connection to a missing localId, a cycle of blocks, another TC6 version, an entity bomb, not
XML, a file over the size limit) refuses the upload with a clear error and leaves the running set
running and nothing stored."""

from __future__ import annotations

import sys

import pytest
from agent_helpers import IRPD, ROOT, tar_gz
from live_processes import wait_until
from test_st_upload import Cell, parts

sys.path.insert(0, str(ROOT / "tests" / "python" / "plcopen"))
import plcopen_xml as x  # noqa: E402
from plcopen_live import shared  # noqa: E402

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    yield c
    c.close()


def test_a_plcopen_project_uploaded_with_irpctl_is_imported_and_runs(cell, tmp_path, capsys):
    folder = tmp_path / "plc"
    folder.mkdir()
    (folder / "plc.xml").write_bytes(shared("tutorial_xor_xnor").read_bytes())
    (folder / "ioconfig.xml").write_bytes(b"<ioconfig><channel name='x'/></ioconfig>\n")
    code, said = cell.irpctl(capsys, "upload", str(folder), "--activate", "--mode", "auto")
    assert code == 0, said
    set_id = cell.running()
    kinds = {f["path"]: f["kind"] for f in cell.call("GET", f"/sets/{set_id}").json()["files"]}
    assert kinds["plc.xml"] == "plcopen" and kinds["ioconfig.xml"] == "config", kinds
    assert kinds["instance0.so"] == "thread_module" and kinds["module.xml"] == "module_xml", kinds
    assert cell.read("instance0.OUTPUT_1") is True  # XNOR of FALSE and FALSE
    r = cell.call("PUT", "/variables/instance0.INPUT_0", json={"value": True})
    assert r.status_code in (200, 204), r.text
    wait_until(lambda: cell.read("instance0.OUTPUT_0") is True, 10)  # XOR of TRUE and FALSE

    # the rung changed in the editor (the XOR coil made negated) and uploaded again: activated online,
    # the inputs keep their values
    xml = (folder / "plc.xml").read_bytes()
    (folder / "plc.xml").write_bytes(
        xml.replace(b'<coil localId="7" negated="false"', b'<coil localId="7" negated="true"')
    )
    code, said = cell.irpctl(capsys, "upload", str(folder), "--activate")
    assert code == 0 and "online" in said, said
    assert cell.running() != set_id
    assert cell.read("instance0.INPUT_0") is True
    wait_until(lambda: cell.read("instance0.OUTPUT_0") is False, 10)


def test_an_archive_of_a_folder_holding_a_plcopen_project_is_built(cell):
    archive = tar_gz([("myset/plc.xml", shared("tutorial_not_or_nor").read_bytes())])
    r = cell.call("POST", "/sets", files=[("archive", ("set.tar.gz", archive))])
    assert r.status_code == 201, r.text
    assert {f["path"]: f["kind"] for f in r.json()["files"]}["plc.xml"] == "plcopen"


def ladder(body: str, *variables: str) -> bytes:
    iface = x.section("localVars", *variables)
    return x.project(x.pou("main", "program", iface, "LD", body), instances=x.config("main", interval="T#10ms"))


GOOD_RUNG = x.rail(1) + x.contact(17, "Start", 1, 100, 0) + x.coil(18, "Motor", 17, 300, 0)


def refused(cell: Cell, data: bytes, status: int = 400) -> dict:
    """Uploads plc.xml; a refusal; the running set runs on and nothing new is stored.  The answer."""
    before, stored = cell.running(), cell.sets()
    r = cell.call("POST", "/sets", files=parts({"plc.xml": data}))
    assert r.status_code == status, r.text
    assert cell.running() == before and cell.sets() == stored
    return r.json()


def test_an_error_in_a_rung_names_the_element_and_leaves_the_running_set(cell):
    body = refused(cell, ladder(GOOD_RUNG, x.var("Motor", "BOOL")))
    (first,) = body["problems"]
    assert first["file"] == "plc.xml" and first["origin"] == "main (LD) rung 1, contact localId 17"
    assert first["message"].startswith("'Start' is not declared")
    assert "main (LD) rung 1, contact localId 17: 'Start' is not declared" in body["detail"]


@pytest.mark.parametrize(
    "data, says",
    [
        (
            ladder(x.rail(1) + x.contact(17, "Start", 99, 100, 0), x.var("Start", "BOOL")),
            "a connection to localId 99, which no element has",
        ),
        (
            ladder(GOOD_RUNG, x.var("Start", "BOOL"), x.var("Motor", "BOOL")).replace(b"tc6_0201", b"tc6_0200"),
            "it is TC6 XML 2.0",
        ),
        (
            b'<?xml version="1.0"?>\n<!DOCTYPE project [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;">]>\n'
            + ladder(GOOD_RUNG).split(b"?>", 1)[1].replace(b'name="test"', b'name="&b;"'),
            "entities are not expanded",
        ),
    ],
    ids=["missing-localId", "tc6-2.0", "entity-bomb"],
)
def test_bad_plcopen_input_is_refused_and_the_running_set_runs_on(cell, data, says):
    body = refused(cell, data)
    assert says in body["detail"], body


def test_not_xml_and_a_file_over_the_limit_are_refused(cell):
    body = refused(cell, b"<project xmlns='http://www.plcopen.org/xml/tc6_0201'><pou>")
    assert "malformed XML" in body["detail"] or "not well-formed XML" in body["detail"], body
    big = ladder(GOOD_RUNG, x.var("Start", "BOOL"), x.var("Motor", "BOOL"))
    big = big.replace(b"</project>", b"<!--" + b"x" * (50 << 20) + b"--></project>")
    before, stored = cell.running(), cell.sets()
    r = cell.call("POST", "/sets", files=parts({"plc.xml": big}))
    assert r.status_code in (400, 413), r.text
    assert "bytes" in r.json()["detail"], r.text
    assert cell.running() == before and cell.sets() == stored


def test_a_cycle_of_blocks_is_refused_naming_them(cell):
    body_xml = x.blocks_in_a_cycle("n")
    data = x.project(
        x.pou("main", "program", x.section("localVars", x.var("n", "INT")), "FBD", body_xml), instances=x.config("main")
    )
    body = refused(cell, data)
    assert "a cycle without a variable" in body["detail"] and "(ADD)" in body["detail"] and "(MUL)" in body["detail"]
