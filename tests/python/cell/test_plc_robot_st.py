"""test_plc_robot_st.py -- the cell's PLC in Structured Text (config/sets/plc-robot-st/main.st, built
by `stc build`) does what the C++ PLC (config/sets/plc-robot's main.so) does, period by period.

Both run in a real irpd of their own, each beside the same twin module (plc_twin.cpp, priority 2,
before the PLC): it gives the PLC the same operator panel (PLC_IN, I0, I1) and drives' IO_STATUS in
the same period, steps the simulated robot of the PLC tests on the PLC's requests, and records
every period what the PLC wrote: PLC_OUT, O0 and the robot request (eOpCode, nSeq, speeds,
targets).  Everything the twin does is a function of the number of its run, so the two records are
equal line for line when the two programs are; the script goes through a cycle, CycleMode with
Override changes (2.0, NaN), Stop, a drive fault and Reset, power removed mid-cycle (1010), and lost
drive communication (8, WaitingForDrives).  The alarms the PLC raises and clears (irpd's alarm
segment: id, period, value, detail) are compared too."""

from __future__ import annotations

import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import BUILD, IRPD, ROOT, copy_cell, dispatching, start_irpd, stop, wait_until  # noqa: E402

sys.path.insert(0, str(ROOT / "st"))
from stc_compiler import sdk  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.alarms.segment import AlarmSegment, RingReader  # noqa: E402
from indurop_agent.irpd.client import IrpdClient  # noqa: E402
from indurop_agent.irpd.variables import Segment  # noqa: E402

CELL = BUILD / "sets" / "plc-robot"  # the C++ cell as built
ST_SET = ROOT / "config" / "sets" / "plc-robot-st"
PERIODS = 1450  # 14.5 s at 10 ms: the whole script of plc_twin.cpp

pytestmark = pytest.mark.skipif(
    not (CELL / "main.so").exists() or not IRPD.exists() or shutil.which("g++") is None,
    reason=f"needs the plc-robot cell built ({CELL}), irpd and g++",
)


def _twin(folder: Path) -> Path:
    """plc_twin.so, compiled against the C++ cell's generated.h (cell.glb) as the ST set's modules are."""
    kit = sdk.find(None, None)
    so = folder / "plc_twin.so"
    cmd = [kit.cxx, *sdk.CXXFLAGS, *[f"-I{d}" for d in kit.includes], f"-I{CELL}", f"-I{ROOT / 'tests/cpp/support'}"]
    cmd += [str(Path(__file__).with_name("plc_twin.cpp")), *sdk.LDFLAGS, "-o", str(so), *kit.libraries]
    cmd += [f"-L{kit.libdir}", f"-Wl,-rpath,{kit.libdir}", "-lindurop"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return so


def _twin_entry(trace: Path) -> ET.Element:
    m = ET.Element("module")
    for tag, text in (
        ("name", "twin"),
        ("filename", "./plc_twin.so"),
        ("moduletype", "thread"),
        ("operationtype", "periodic"),
        ("period", "10000000"),
        ("priority", "2"),  # Robot.so's place: before the PLC (3)
    ):
        ET.SubElement(m, tag).text = text
    props = ET.SubElement(m, "property")
    ET.SubElement(props, "value", name="trace").text = str(trace)
    ET.SubElement(props, "value", name="periods").text = str(PERIODS)
    return m


def _with_twin(module_xml: Path, out: Path, trace: Path) -> Path:
    """The set's module.xml with the PLC kept and the robot, the I/O dispatcher and the drive simulator
    replaced by the twin."""
    root = ET.parse(module_xml).getroot()
    for m in root.findall("module"):
        if (m.findtext("filename") or "").strip() != "./main.so":
            root.remove(m)
    root.append(_twin_entry(trace))
    ET.ElementTree(root).write(out, encoding="unicode", xml_declaration=True)
    return out


def _cpp_cell(folder: Path, twin: Path) -> Path:
    folder.mkdir()
    for f in ("main.so", "layout.json"):
        shutil.copy(CELL / f, folder / f)
    shutil.copy(twin, folder / twin.name)
    return _with_twin(CELL / "module.xml", folder / "module.xml", folder / "trace.txt")


def _st_cell(folder: Path, twin: Path) -> Path:
    folder.mkdir()
    shutil.copy(twin, folder / twin.name)
    return _stc_build(folder, _with_twin(CELL / "module.xml", folder / "hand.xml", folder / "trace.txt"))


def _stc_build(folder: Path, hand: Path) -> Path:
    """stc build of main.st into `folder` with the other modules of `hand` (a module.xml there): its
    layout keeps cell.glb's, the C++ modules' layout."""
    r = subprocess.run(
        [
            sys.executable,
            str(ROOT / "st" / "stc"),
            "build",
            "-o",
            str(folder),
            "--glb",
            str(ROOT / "config" / "sets" / "plc-robot" / "cell.glb"),
            "--set-layout",
            str(CELL / "layout.json"),
            "--module-xml",
            str(hand),
            str(ST_SET / "main.st"),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    return folder / "module.xml"


def _run(xml: Path, tmp: Path, instance: str):
    return start_irpd(tmp / f"{instance}.sock", xml, instance)


def _plc_alarms(sock: Path) -> list[tuple]:
    """What the PLC module `main` raised and cleared, with the period of each: (cycle, id, raised,
    value, detail), from irpd's alarm segment."""
    client = IrpdClient(str(sock), timeout_s=30)
    try:
        seg = AlarmSegment(client.request("alarms")["segment"])
    finally:
        client.close()
    try:
        main = [s.index for s in seg.sources() if s.name == "main"]
        records = RingReader(seg).read().records
        return [(r.cycle, r.id, r.raised, r.value, r.text) for r in records if r.source in main]
    finally:
        seg.close()


def test_the_st_cell_writes_what_the_cpp_cell_writes_period_by_period(tmp_path):
    twin = _twin(tmp_path)
    cpp_xml = _cpp_cell(tmp_path / "cpp", twin)
    st_xml = _st_cell(tmp_path / "st", twin)
    traces = [cpp_xml.parent / "trace.txt", st_xml.parent / "trace.txt"]
    irpds = [_run(cpp_xml, tmp_path, f"cell-cpp-{id(tmp_path)}"), _run(st_xml, tmp_path, f"cell-st-{id(tmp_path)}")]
    try:
        wait_until(lambda: all(t.exists() for t in traces) or any(p.poll() is not None for p in irpds), 90, 0.2)
        assert all(p.poll() is None for p in irpds), "an irpd ended before the end of the script"
        alarms = [_plc_alarms(tmp_path / f"{p.instance}.sock") for p in irpds]
    finally:
        for p in irpds:
            stop(p)
    cpp, st = (t.read_text().splitlines() for t in traces)
    assert len(cpp) == len(st) == PERIODS
    for a, b in zip(cpp, st):
        assert b == a, f"the ST cell differs from the C++ cell:\n  C++: {a}\n  ST:  {b}"
    assert alarms[1] == alarms[0], "the ST cell's alarms differ from the C++ cell's"
    raised = {a[1] for a in alarms[0] if a[2]}
    assert {4, 1010, 8, 1000} <= raised, alarms[0]
    # the script went where it was meant to: cycles, the faults of the robot and of the program
    text = "\n".join(cpp)
    for seen in ("Cycles=2", "Step=8", "ErrorID=4 ", "ErrorID=1010", "ErrorID=8 ", "WaitingForDrives=1", "eOpCode=5"):
        assert seen in text, seen


def test_the_st_cell_runs_the_pick_and_place_cycle_with_the_robot_and_its_drives(tmp_path):
    """The ST PLC in the cell as it runs by default: Robot.so, the I/O dispatcher, the simulated
    drives on Modbus TCP, all the plc-robot set's own modules."""
    xml, _ = copy_cell(tmp_path / "cell")
    xml = _stc_build(xml.parent, xml.rename(xml.with_name("hand.xml")))
    irpd = start_irpd(tmp_path / "irpd.sock", xml, f"cell-st-live-{id(tmp_path)}")
    control = IrpdClient(str(tmp_path / "irpd.sock"), timeout_s=30)
    try:
        status = wait_until(lambda: dispatching(control), 30)
        assert [m["name"] for m in control.request("modules")] == ["Robot", "libiodispat", "drivesim", "main"]
        vars = Segment(status["shared_memory"]["variables"])
        read = vars.read
        wait_until(lambda: read("PLC_ROBOT.IO_STATUS.cycles") > 0 and read("PLC_ROBOT.IO_STATUS.comm_lost[0]") == 0)
        control.request("write", path="PLC_ROBOT.PLC_IN.Enable", value=1)
        wait_until(lambda: read("PLC_ROBOT.PLC_OUT.Powered") == 1, 30)
        control.request("write", path="PLC_ROBOT.I0", value=1)
        steps = set()

        def cycled():
            steps.add(read("main.Step"))
            assert read("PLC_ROBOT.PLC_OUT.Error") == 0, read("PLC_ROBOT.PLC_OUT.ErrorID")
            return read("PLC_ROBOT.PLC_OUT.Cycles") >= 1

        wait_until(cycled, 60, 0.005)
        assert steps >= set(range(1, 9)), steps  # every step, seen in the program's own variable
        assert read("PLC_ROBOT.PLC_OUT.Done") == 1 and read("main.Power.Status") is True
        commanded = [read(f"PLC_ROBOT.ROBOT_MODULE_STATE.dCmdJoint[{i}]") for i in range(6)]
        assert commanded == pytest.approx([0, 0, 0, 0, 1.5708, 0], abs=1e-6)  # HOME, where the cycle ends
        vars.close()
    finally:
        control.close()
        stop(irpd)
