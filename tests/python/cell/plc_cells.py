# plc_cells.py -- the cell's PLC run beside the twin module (plc_twin.cpp) in an irpd of its own, for
# the tests that compare the C++, ST and LD programs of the cell period by period
# (test_plc_robot_st.py, test_plc_robot_ld.py): the twin compiled against the C++ cell's cell.glb, a
# set's module.xml with the PLC kept and the other modules replaced by the twin, stc build of a
# set's sources, and each cell's record and alarms.

from __future__ import annotations

import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from live_processes import BUILD, IRPD, ROOT, start_irpd, stop, wait_until  # noqa: E402

sys.path.insert(0, str(ROOT / "st"))
from stc_compiler import sdk  # noqa: E402

sys.path.insert(0, str(ROOT / "agent"))
from indurop_agent.alarms.segment import AlarmSegment, RingReader  # noqa: E402
from indurop_agent.irpd.client import IrpdClient  # noqa: E402

CELL = BUILD / "sets" / "plc-robot"  # the C++ cell as built
PERIODS = 1450  # 14.5 s at 10 ms: the whole script of plc_twin.cpp
BUILT = (CELL / "main.so").exists() and IRPD.exists() and shutil.which("g++") is not None
NOT_BUILT = f"needs the plc-robot cell built ({CELL}), irpd and g++"


def twin(folder: Path) -> Path:
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


def cpp_cell(folder: Path, twin: Path) -> Path:
    folder.mkdir()
    for f in ("main.so", "layout.json"):
        shutil.copy(CELL / f, folder / f)
    shutil.copy(twin, folder / twin.name)
    return _with_twin(CELL / "module.xml", folder / "module.xml", folder / "trace.txt")


def st_cell(folder: Path, twin: Path, sources: list[Path]) -> Path:
    """A cell whose PLC is `sources` (ST, or PLCopen XML) built by stc beside the twin."""
    folder.mkdir()
    shutil.copy(twin, folder / twin.name)
    return stc_build(folder, _with_twin(CELL / "module.xml", folder / "hand.xml", folder / "trace.txt"), sources)


def stc_build(folder: Path, hand: Path, sources: list[Path]) -> Path:
    """stc build of `sources` into `folder` with the other modules of `hand` (a module.xml there): its
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
            *map(str, sources),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    return folder / "module.xml"


def run_cells(tmp: Path, cells: dict[str, Path]) -> dict[str, tuple[list[str], list[tuple]]]:
    """Each cell (name -> its module.xml) in an irpd of its own, at once, to the end of the twin's
    script: name -> (the twin's record, one line a period; the PLC's alarms)."""
    traces = {n: xml.parent / "trace.txt" for n, xml in cells.items()}
    irpds = {n: start_irpd(tmp / f"cell-{n}-{id(tmp)}.sock", xml, f"cell-{n}-{id(tmp)}") for n, xml in cells.items()}
    try:
        wait_until(
            lambda: all(t.exists() for t in traces.values()) or any(p.poll() is not None for p in irpds.values()),
            90,
            0.2,
        )
        assert all(p.poll() is None for p in irpds.values()), "an irpd ended before the end of the script"
        alarms = {n: plc_alarms(tmp / f"{p.instance}.sock") for n, p in irpds.items()}
    finally:
        for p in irpds.values():
            stop(p)
    return {n: (traces[n].read_text().splitlines(), alarms[n]) for n in cells}


def assert_same(reference: tuple, other: tuple, what: str) -> None:
    """`other` cell's record and alarms are the reference's, period by period."""
    (ref, ref_alarms), (got, got_alarms) = reference, other
    assert len(ref) == len(got) == PERIODS
    for a, b in zip(ref, got):
        assert b == a, f"the {what} cell differs from the C++ cell:\n  C++: {a}\n  {what}:  {b}"
    assert got_alarms == ref_alarms, f"the {what} cell's alarms differ from the C++ cell's"


def plc_alarms(sock: Path) -> list[tuple]:
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
