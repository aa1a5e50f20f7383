"""test_st_upload.py -- sets written in Structured Text, uploaded to a real agent beside a real irpd
(running the paper's Figure 1 set): with irpctl and with POST /sets the .st sources are compiled on
the appliance (stc build), stored with what was built, activated and run, their variables listed
with their IEC types and read by path; a type error, a syntax error, a 10 MB source and NUL bytes refuse the upload with the
compiler's errors in place (file, line, column, code, message) and leave the running set running;
a build over the agent's time limit is stopped with an error that names the setting.  The ST cell as
the build makes it (build/sets/plc-robot-st) is such a set: uploaded, main.st is compiled again."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest
from agent_helpers import BUILD, FIG1, IRPD, ROOT, LiveCell, copy_cell, free_port, st_configuration
from live_processes import wait_until

pytestmark = pytest.mark.skipif(not IRPD.exists(), reason=f"irpd is not built ({IRPD})")

COUNTER = """\
PROGRAM Counter
VAR
  count : DINT;
  step : DINT := {step};
END_VAR
count := count + step;
END_PROGRAM
"""
CONFIG = st_configuration("Counter")
TYPE_ERROR = "PROGRAM Counter\nVAR\n  count : DINT;\n  flag : BOOL;\nEND_VAR\nflag := count;\nEND_PROGRAM\n"
MIRROR = """\
PROGRAM Mirror
VAR
  seen : UDINT;
  tick AT %knu.Robot.tick : UDINT;
END_VAR
seen := tick;
END_PROGRAM
"""
SYNTAX_ERROR = "PROGRAM Counter\nVAR\n  count : DINT;\nEND_VAR\ncount := count + ;\nEND_PROGRAM\n"


def st_set(main: str) -> dict[str, bytes]:
    return {"main.st": main.encode(), "config.st": CONFIG.encode()}


def parts(files: dict[str, bytes]) -> list[tuple[str, tuple[str, bytes]]]:
    return [("files", (path, content)) for path, content in files.items()]


class Cell(LiveCell):
    """irpd on Figure 1 and an agent (its settings in agent.json), with the admin token."""

    def __init__(self, tmp: Path, **settings):
        super().__init__(tmp, FIG1, instance=f"st-upload-{free_port()}", **settings)

    def running(self) -> str:
        status = self.call("GET", "/status").json()
        assert status.get("state") != "stopped", status
        return status["set_id"]

    def sets(self) -> list[str]:
        return [s["id"] for s in self.call("GET", "/sets").json()]

    def read(self, path: str):
        r = self.call("GET", f"/variables/{path}")
        assert r.status_code == 200, r.text
        return r.json()["value"]


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    yield c
    c.close()


def counts_up(cell: Cell, path: str = "Main.count") -> None:
    first = cell.read(path)
    deadline = time.monotonic() + 10
    while cell.read(path) == first:
        assert time.monotonic() < deadline, f"{path} stays {first}: the ST program does not run"
        time.sleep(0.05)


def test_an_st_set_uploaded_with_irpctl_is_compiled_activated_and_runs(cell, tmp_path, capsys):
    folder = tmp_path / "plc"
    folder.mkdir()
    for path, content in st_set(COUNTER.format(step=1)).items():
        (folder / path).write_bytes(content)
    code, said = cell.irpctl(capsys, "upload", str(folder), "--activate", "--mode", "auto")
    assert code == 0, said
    set_id = cell.running()
    kinds = {f["path"]: f["kind"] for f in cell.call("GET", f"/sets/{set_id}").json()["files"]}
    assert kinds["main.st"] == "st" and kinds["config.st"] == "st", kinds  # the sources are kept in the set
    assert kinds["module.xml"] == "module_xml" and kinds["layout.json"] == "layout", kinds
    assert kinds["Main.so"] == "thread_module", kinds
    counts_up(cell)
    # the program's variables are shared variables: listed with their IEC type beside the C++ one
    listed = {v["path"]: v for v in cell.call("GET", "/variables").json()["variables"]}
    assert (listed["Main.count"]["type"], listed["Main.count"]["iec_type"]) == ("int32_t", "DINT"), listed["Main.count"]

    # a change of code alone, laid out against the running layout: activated online (irpctl's
    # default mode), the counter keeps its value
    (folder / "main.st").write_text(COUNTER.format(step=2))
    before = cell.read("Main.count")
    code, said = cell.irpctl(capsys, "upload", str(folder), "--activate")
    assert code == 0, said
    assert "online" in said, said
    assert cell.running() != set_id
    assert cell.read("Main.count") > before
    counts_up(cell)


def test_an_st_set_posted_to_sets_is_stored_with_what_was_built(cell):
    r = cell.call("POST", "/sets", files=parts(st_set(COUNTER.format(step=1))))
    assert r.status_code == 201, r.text
    stored = r.json()
    assert stored["validation"]["valid"] is True, stored["validation"]
    assert {f["path"] for f in stored["files"]} >= {"main.st", "config.st", "module.xml", "layout.json", "Main.so"}
    # the same sources against the same running layout: the same build, the same set
    again = cell.call("POST", "/sets", files=parts(st_set(COUNTER.format(step=1))))
    assert again.status_code == 201 and again.json()["id"] == stored["id"], again.text
    r = cell.call("POST", f"/sets/{stored['id']}/activate", json={"mode": "auto"})
    assert r.status_code == 200, r.text
    counts_up(cell)


def test_st_beside_the_sets_cpp_modules_is_laid_out_with_their_glb_and_activated_online(cell):
    """Figure 1's C++ modules (built against knuRobot.glb and joint.glb: its layout.json) and an ST
    program bound to one of their variables: the .glb files and layout.json go into the build, the
    hand-written module.xml keeps its modules, and the C++ modules are kept by the swap."""
    files = {p.relative_to(FIG1.parent).as_posix(): p.read_bytes() for p in FIG1.parent.rglob("*") if p.is_file()}
    for glb in ("knuRobot.glb", "joint.glb"):
        files[glb] = (ROOT / "config" / "sets" / "paper-figures" / glb).read_bytes()
    files["mirror.st"] = MIRROR.encode()
    files["config.st"] = st_configuration("Mirror").encode()
    r = cell.call("POST", "/sets", files=parts(files))
    assert r.status_code == 201, r.text
    stored = r.json()
    assert stored["validation"]["valid"] is True and stored["validation"]["online"] is True, stored["validation"]
    r = cell.call("POST", f"/sets/{stored['id']}/activate")
    assert r.status_code == 200, r.text
    assert "cntr2" in r.json()["kept"] and r.json()["started"] == ["Main"], r.json()
    counts_up(cell, "Main.seen")  # the ST program reads what cntr2 writes


RETYPED = """\
PROGRAM Counter
VAR
  count : DINT;
  w : {w};
  x : {x};
END_VAR
count := count + 1;
w := w + 1;
END_PROGRAM
"""


def test_a_retype_that_loses_values_needs_the_managed_restart_and_a_widening_one_converts_online(
    cell, tmp_path, capsys
):
    """INT -> DINT keeps its value online; INT -> BOOL cannot be converted without loss: the dry run
    (API, irpctl) names it with its types and offers the managed restart, an online activation is
    refused and leaves the running set as it was, the restart runs it with x at its initial value."""
    r = cell.call("POST", "/sets", files=parts(st_set(RETYPED.format(w="INT", x="INT := 7"))))
    assert r.status_code == 201, r.text
    assert cell.call("POST", f"/sets/{r.json()['id']}/activate", json={"mode": "auto"}).status_code == 200
    counts_up(cell, "Main.w")
    assert cell.read("Main.x") == 7

    # INT -> DINT: converted online, the count goes on from where it was
    r = cell.call("POST", "/sets", files=parts(st_set(RETYPED.format(w="DINT", x="INT := 7"))))
    assert r.status_code == 201, r.text
    widened = r.json()
    assert widened["validation"]["online"] is True, widened["validation"]
    converted = widened["validation"]["variables"]["converted"]
    assert [(c["path"], c["from_type"], c["to_type"]) for c in converted] == [("Main.w", "int16_t", "int32_t")]
    before = cell.read("Main.w")
    r = cell.call("POST", f"/sets/{widened['id']}/activate")
    assert r.status_code == 200 and r.json()["mode"] == "online", r.text
    assert cell.read("Main.w") >= before, "the widened variable kept its value"
    counts_up(cell, "Main.w")

    # INT -> BOOL: named by the dry run with its types, offered the managed restart
    r = cell.call("POST", "/sets", files=parts(st_set(RETYPED.format(w="DINT", x="BOOL := TRUE"))))
    assert r.status_code == 201, r.text
    narrowed = r.json()
    validation = narrowed["validation"]
    assert validation["valid"] is True and validation["online"] is False, validation
    moved = validation["variables"]["moved"]
    assert [(m["path"], m["from_type"], m["to_type"]) for m in moved] == [("Main.x", "INT", "BOOL")], moved
    reason = validation["restart"]["reason"]
    assert "'Main.x' INT -> BOOL" in reason and "managed restart" in reason, reason
    code, said = cell.irpctl(capsys, "check", narrowed["id"])
    assert "online: no, only a restart of irpd can run it" in said and "'Main.x' INT -> BOOL" in said, said
    assert "moved Main.x INT -> BOOL (not convertible without loss" in said, said

    # online: refused, the running set runs on untouched
    running, w = cell.running(), cell.read("Main.w")
    r = cell.call("POST", f"/sets/{narrowed['id']}/activate", json={"mode": "online"})
    assert r.status_code == 409, r.text
    assert "'Main.x' INT -> BOOL" in r.json()["detail"] and "mode restart" in r.json()["detail"], r.text
    assert cell.running() == running and cell.read("Main.x") == 7 and cell.read("Main.w") > w

    # the managed restart runs it: x starts at its initial value
    r = cell.call("POST", f"/sets/{narrowed['id']}/activate", json={"mode": "restart"})
    assert r.status_code == 200 and r.json()["mode"] == "restart", r.text
    assert cell.running() == narrowed["id"]
    assert cell.read("Main.x") is True
    counts_up(cell, "Main.w")


def refused_in_place(cell: Cell, files: dict[str, bytes], status: int = 400) -> dict:
    """Uploads `files`, expects a refusal with the compiler's errors; the running set runs on,
    nothing new is stored.  The first problem."""
    before, stored = cell.running(), cell.sets()
    r = cell.call("POST", "/sets", files=parts(files))
    assert r.status_code == status, r.text
    body = r.json()
    assert body["problems"], body
    first = body["problems"][0]
    assert {k: body[k] for k in ("file", "line", "column")} == {k: first[k] for k in ("file", "line", "column")}
    assert "do not compile" in body["detail"]
    assert cell.running() == before and cell.sets() == stored
    return first


def test_a_type_error_refuses_the_upload_with_its_place(cell, tmp_path, capsys):
    first = refused_in_place(cell, st_set(TYPE_ERROR))
    assert {k: first[k] for k in ("file", "line", "column", "code")} == {
        "file": "main.st",
        "line": 6,
        "column": 9,
        "code": "type",
    }, first
    assert "DINT" in first["message"] and "BOOL" in first["message"], first

    folder = tmp_path / "bad"
    folder.mkdir()
    for path, content in st_set(TYPE_ERROR).items():
        (folder / path).write_bytes(content)
    code, said = cell.irpctl(capsys, "upload", str(folder), "--activate")
    assert code != 0
    assert f"main.st:6:9: error[type]: {first['message']}" in said.splitlines(), said


def test_a_syntax_error_refuses_the_upload_with_its_place(cell):
    first = refused_in_place(cell, st_set(SYNTAX_ERROR))
    assert {k: first[k] for k in ("file", "line", "column", "code")} == {
        "file": "main.st",
        "line": 5,
        "column": 18,
        "code": "syntax",
    }, first
    assert "expected an expression" in first["message"]


def test_a_10_mb_source_and_nul_bytes_get_clear_errors(cell):
    big = (COUNTER.format(step=1) + "(* " + "x" * (10 << 20) + " *)\n").encode()
    first = refused_in_place(cell, {"main.st": big, "config.st": CONFIG.encode()})
    assert first["file"] == "main.st" and first["code"] == "too-large", first
    nul = COUNTER.format(step=1).replace("count := count", "count :=\0 count").encode()
    first = refused_in_place(cell, {"main.st": nul, "config.st": CONFIG.encode()})
    assert first["file"] == "main.st" and first["code"] == "encoding" and first["line"] == 6, first


def test_a_build_over_the_time_limit_is_stopped_and_says_which_setting(tmp_path):
    cell = Cell(tmp_path, st_build_timeout_s=0.01)
    try:
        before, stored = cell.running(), cell.sets()
        r = cell.call("POST", "/sets", files=parts(st_set(COUNTER.format(step=1))))
        assert r.status_code == 400, r.text
        assert "took longer than 0.01 s (st_build_timeout_s)" in r.json()["detail"], r.text
        assert cell.running() == before and cell.sets() == stored
        assert not list((tmp_path / "data" / "tmp").iterdir())  # the build's folder is gone
    finally:
        cell.close()


def test_a_source_named_like_an_option_is_compiled_as_a_file(agent):
    """No irpd: the build lays the variables out afresh; "-o.st" reaches stc as a file name."""
    files = {"-o.st": COUNTER.format(step=1).encode(), "config.st": CONFIG.encode()}
    r = agent.client.post("/api/v1/sets", files=parts(files), headers=agent.h())
    assert r.status_code == 201, r.text
    assert {f["path"] for f in r.json()["files"]} >= {"-o.st", "config.st", "module.xml", "layout.json", "Main.so"}


def test_a_build_that_writes_a_file_over_max_file_bytes_is_stopped(make_agent):
    """The module the build writes is larger than a set's file may be: 413 naming the limit, nothing stored."""
    agent = make_agent(max_file_bytes=20_000)
    r = agent.client.post("/api/v1/sets", files=parts(st_set(COUNTER.format(step=1))), headers=agent.h())
    assert r.status_code == 413, r.text
    assert r.json()["detail"].endswith("the limit per file of a set is 20000 (max_file_bytes)"), r.text
    assert r.json()["file"] == "Main.so"
    assert not [p for p in agent.stored() if not p.startswith("tmp")] and not list((agent.data / "tmp").iterdir())


ST_CELL = BUILD / "sets" / "plc-robot-st"  # the paper's cell with its PLC in ST, as the build makes it
LD_CELL = BUILD / "sets" / "plc-robot-ld"  # the same cell with its PLC drawn in ladder (plc.xml, PLCopen XML)
UPLOADED_ST = ("  LastStep : DINT;\n", "  LastStep : DINT;\n  Uploaded : DINT := 7;\n")
UPLOADED_XML = (
    '<variable name="Robot">',
    '<variable name="Uploaded"><type><DINT/></type><initialValue><simpleValue value="7"/></initialValue>'
    '</variable><variable name="Robot">',
)


@pytest.mark.parametrize(
    ("built", "source", "kind", "edit"),
    [
        pytest.param(ST_CELL, "main.st", "st", UPLOADED_ST, id="st"),
        pytest.param(LD_CELL, "plc.xml", "plcopen", UPLOADED_XML, id="ld"),
    ],
)
def test_the_built_st_cell_is_an_upload_that_the_agent_builds_again_from_main_st(
    tmp_path, capsys, built, source, kind, edit
):
    """build/sets/plc-robot-st holds its sources (main.st, cell.glb) beside what irpd runs, and no
    generated C++ (so does plc-robot-ld, with plc.xml): irpd runs the folder, the folder (with a
    variable added to the source, so that only a build on the appliance has it) is uploaded with
    irpctl, compiled, activated, and the cell cycles."""
    if not (built / "main.so").exists():
        pytest.skip(f"the cell is not built ({built})")
    folder = tmp_path / built.name
    config, _ = copy_cell(folder, cell=built)  # its drive simulator on a port of its own
    assert (folder / source).is_file() and (folder / "cell.glb").is_file(), sorted(os.listdir(folder))
    assert not list(folder.glob("*.cpp")), "the generated C++ belongs to the build tree, not to the set"
    main = folder / source
    main.write_text(main.read_text().replace(*edit, 1))
    cell = LiveCell(tmp_path, config, instance=f"{built.name}-upload-{free_port()}")
    try:
        code, said = cell.irpctl(capsys, "upload", str(folder), "--activate", "--mode", "auto")
        assert code == 0, said
        status = cell.call("GET", "/status").json()
        kinds = {f["path"]: f["kind"] for f in cell.call("GET", f"/sets/{status['set_id']}").json()["files"]}
        assert (kinds[source], kinds["cell.glb"], kinds["main.so"]) == (kind, "glb", "thread_module"), kinds

        def read(path: str):
            r = cell.call("GET", f"/variables/{path}")
            return r.json()["value"] if r.status_code == 200 else None

        def write(path: str, value) -> None:
            r = cell.call("PUT", f"/variables/{path}", json={"value": value})
            assert r.status_code == 200, r.text

        assert read("main.Uploaded") == 7  # main.so was built from the uploaded source
        write("PLC_ROBOT.PLC_IN.Enable", 1)
        wait_until(lambda: read("PLC_ROBOT.PLC_OUT.Powered") == 1, 30, 0.05)
        write("PLC_ROBOT.I0", 1)
        wait_until(lambda: (read("main.Step") or 0) >= 3, 60, 0.05)  # the cycle runs: past the first moves
    finally:
        cell.close()


def test_the_compiler_runs_at_the_lowest_cpu_priority(make_agent, tmp_path):
    """A set compiling on the appliance must leave the agent's own work (the recorder, OPC UA, the API)
    its share of the CPU: stc, and the C++ compiler it starts, run at nice 19.  An stc that reports
    its niceness and fails shows what the agent started it with."""
    fake = tmp_path / "stc"
    fake.write_text("import os, sys\nprint(f'stc ran at nice {os.nice(0)}', file=sys.stderr)\nsys.exit(3)\n")
    agent = make_agent(stc=fake)
    r = agent.client.post("/api/v1/sets", files=parts(st_set(COUNTER.format(step=1))), headers=agent.h())
    assert r.status_code == 500, r.text
    assert "stc ran at nice 19" in r.json()["detail"], r.text
