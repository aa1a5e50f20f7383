#!/usr/bin/env python3
# generate.py -- writes plc.xml, the plc-robot cell's PLC program as a PLCopen XML 2.01 project whose
# program PickAndPlace is drawn in ladder (LD): the rungs of config/sets/plc-robot-st/main.st (power,
# stop, reset, start, the eight steps of the pick-and-place cycle and their faults) as contacts, coils
# and blocks with laid-out positions, between a first rung that reads the inputs and a last one that
# writes the outputs and alarms (ST function blocks, cell_st.py).  `generate.py --check` exits 1 when
# the committed plc.xml is not what this script writes (tests/python/cell/test_plc_robot_ld.py).
#   python3 config/sets/plc-robot-ld/generate.py [--check]

from __future__ import annotations

import datetime
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path[:0] = [str(ROOT / "st"), str(ROOT / "plcopen"), str(HERE)]

from cell_st import CONFIGURATION, INPUTS, OUTPUTS, PROGRAM  # noqa: E402
from ladder import Block, Coil, Contact, Drawing, Rung  # noqa: E402
from plcopen_export import export  # noqa: E402
from plcopen_import.read import q  # noqa: E402
from stc_compiler.parse import parse_text  # noqa: E402

OUT = HERE / "plc.xml"
WHEN = datetime.datetime(2026, 12, 7, tzinfo=datetime.UTC)  # fixed: the same rungs give the same file
SOURCE = "plc-robot-ld.st"  # the ST text's name while it is parsed (ST bodies are copied from it)


def N(var: str) -> Contact:  # noqa: N802 -- a normally closed contact, as drawn: -|/|-
    return Contact(var, negated=True)


def C(var: str) -> Contact:  # noqa: N802 -- a normally open contact: -| |-
    return Contact(var)


def sel(g: list[Contact], keep: str, new: str, comment: str | None = None) -> Rung:
    """target := new when the contacts conduct, else kept (SEL's G from the rail through them)."""
    return Rung(comment, block=Block("SEL", inputs={"G": g, "IN0": keep, "IN1": new}, outputs={"OUT": keep}))


def compare(op: str, a: str, b: str, bit: str) -> Rung:
    return Rung(block=Block(op, inputs={"IN1": a, "IN2": b}, outputs={"OUT": Coil(bit)}))


def fault(cond: list[Contact], error_id: str, comment: str) -> list[Rung]:
    """main.st's Fault: the first failing block's ErrorID is kept, the error latched, the cycle ended."""
    return [
        sel(cond + [N("ErrorLatched")], "ErrorCode", error_id, comment),
        Rung(contacts=cond, coils=[Coil("ErrorLatched", "set")]),
        sel(cond, "Step", "STEP_IDLE"),
    ]


def move(fb: str, kind: str, step: str, position: str, speed: str) -> Rung:
    block = Block(
        kind,
        fb,
        inputs={"Execute": [C("InStep")], "Position": position, "Velocity": speed, "Acceleration": "ACCEL"},
        in_outs={"AxesGroup": "Robot"},
    )
    return Rung(f"Step {step}: {fb}", block=block)


def outcome(fb: str) -> list[Contact]:
    """main.st's MoveOutcome TRUE: in the step, no error, not aborted, Done."""
    return [C("InStep"), N(f"{fb}.Error"), N(f"{fb}.CommandAborted"), C(f"{fb}.Done")]


def step(step: str, fb: str, kind: str, position: str, speed: str, dwell: str | None, then: str) -> list[Rung]:
    rungs = [compare("EQ", "Step", step, "InStep"), move(fb, kind, step, position, speed)]
    rungs += fault([C("InStep"), C(f"{fb}.Error")], f"{fb}.ErrorID", f"{fb} failed: the cycle ends with its ErrorID")
    rungs.append(sel([C("InStep"), N(f"{fb}.Error"), C(f"{fb}.CommandAborted")], "Step", "STEP_IDLE"))
    if dwell:
        timer = Block("TON", dwell, inputs={"IN": outcome(fb), "PT": "DWELL"})
        rungs += [Rung(f"{dwell}: the gripper's wait", block=timer), sel([C(f"{dwell}.Q")], "Step", then)]
    elif then:
        rungs.append(sel(outcome(fb), "Step", then))
    return rungs


def rungs() -> list[Rung]:
    r = [
        Rung(
            "Read inputs: the panel, the drives, the robot's image",
            block=Block("CellInputs", "Inputs", in_outs={"Robot": "Robot"}),
        )
    ]
    r += [
        Rung(
            "Rung 1: the robot is powered while Enable, once the drives answer",
            [C("Inputs.Enable"), N("Inputs.CommLost")],
            [Coil("PowerOn", "set")],
        ),
        Rung(contacts=[N("Inputs.Enable")], coils=[Coil("PowerOn", "reset")]),
        Rung(block=Block("MC_Power", "Power", inputs={"Enable": [C("PowerOn")]}, in_outs={"AxesGroup": "Robot"})),
    ]
    r += fault([C("Power.Error")], "Power.ErrorID", "MC_Power failed")
    r.append(compare("NE", "Step", "STEP_IDLE", "Busy"))
    r += fault([N("Inputs.Enable"), C("Busy")], "POWER_REMOVED", "Rung 1b: power removed while the cycle runs (1010)")
    r.append(
        Rung(
            "Rung 2: the robot's own error",
            block=Block("MC_GroupReadError", "GroupError", inputs={"Enable": []}, in_outs={"AxesGroup": "Robot"}),
        )
    )
    r.append(sel([C("Inputs.StopReq")], "Step", "STEP_IDLE", "Rung 3: Stop ends the cycle and stops the powered robot"))
    stop = Block(
        "MC_Stop",
        "StopRobot",
        inputs={"Execute": [C("Inputs.StopReq"), C("Power.Status"), C("PowerOn")]},
        in_outs={"AxesGroup": "Robot"},
    )
    r.append(Rung(block=stop))
    r += fault([C("StopRobot.Error")], "StopRobot.ErrorID", "MC_Stop failed")
    reset = Block("MC_Reset", "ResetRobot", inputs={"Execute": [C("Inputs.ResetReq")]}, in_outs={"AxesGroup": "Robot"})
    r.append(Rung("Rung 4: Reset clears the robot's error, then the program's", block=reset))
    r += fault([C("ResetRobot.Error")], "ResetRobot.ErrorID", "MC_Reset failed")
    r.append(Rung(block=Block("R_TRIG", "ResetDone", inputs={"CLK": [C("ResetRobot.Done")]})))
    r.append(Rung(contacts=[C("ResetDone.Q")], coils=[Coil("ErrorLatched", "reset")]))
    r.append(sel([C("ResetDone.Q")], "ErrorCode", "NO_ERROR"))
    r.append(
        Rung(
            "Rung 5: a rising edge of Start begins a cycle",
            block=Block("R_TRIG", "StartEdge", inputs={"CLK": [C("Inputs.StartReq")]}),
        )
    )
    r += [
        compare("EQ", "Step", "STEP_IDLE", "Idle"),
        compare("EQ", "GroupError.GroupErrorID", "NO_ERROR", "NoGroupError"),
    ]
    start = [
        C("StartEdge.Q"),
        N("Inputs.First"),
        C("Idle"),
        C("Power.Status"),
        N("Inputs.StopReq"),
        N("ErrorLatched"),
        C("NoGroupError"),
    ]
    r += [sel(start, "Step", "STEP_HOME"), Rung(contacts=start, coils=[Coil("CycleDone", "reset")])]
    r += step("STEP_HOME", "MoveJ_Home", "MC_MoveAbsolute", "HOME", "Inputs.vJ", None, "STEP_ABOVE_PICK")
    r += step(
        "STEP_ABOVE_PICK", "MoveJ_AbovePick", "MC_MoveAbsolute", "PICK_ABOVE", "Inputs.vJ", None, "STEP_PICK_DOWN"
    )
    r += step("STEP_PICK_DOWN", "MoveL_PickDown", "MC_MoveLinear", "PICK", "Inputs.vL", "PickDwell", "STEP_PICK_UP")
    r += step("STEP_PICK_UP", "MoveL_PickUp", "MC_MoveLinear", "Inputs.PickUp", "Inputs.vL", None, "STEP_ABOVE_PLACE")
    r += step(
        "STEP_ABOVE_PLACE", "MoveJ_AbovePlace", "MC_MoveAbsolute", "PLACE_ABOVE", "Inputs.vJ", None, "STEP_PLACE_DOWN"
    )
    r += step(
        "STEP_PLACE_DOWN", "MoveL_PlaceDown", "MC_MoveLinear", "PLACE", "Inputs.vL", "PlaceDwell", "STEP_PLACE_UP"
    )
    r += step("STEP_PLACE_UP", "MoveL_PlaceUp", "MC_MoveLinear", "Inputs.PlaceUp", "Inputs.vL", None, "STEP_HOME_AGAIN")
    r += step("STEP_HOME_AGAIN", "MoveJ_HomeAgain", "MC_MoveAbsolute", "HOME", "Inputs.vJ", None, "")
    done = outcome("MoveJ_HomeAgain")
    r.append(
        Rung(
            "The cycle is done: counted; CycleMode 1 goes again until Stop",
            block=Block("ADD", inputs={"IN1": "Cycles", "IN2": "ONE"}, outputs={"OUT": "NextCycles"}),
        )
    )
    r.append(sel(done, "Cycles", "NextCycles"))
    r.append(Rung(contacts=done, coils=[Coil("CycleDone", "set")]))
    r.append(compare("EQ", "PLC_ROBOT.PLC_IN.CycleMode", "CYCLE_REPEAT", "Again"))
    r.append(
        Rung(
            block=Block(
                "SEL",
                inputs={"G": [C("Again"), N("Inputs.StopReq")], "IN0": "STEP_IDLE", "IN1": "STEP_HOME"},
                outputs={"OUT": "NextStep"},
            )
        )
    )
    r.append(sel(done, "Step", "NextStep"))
    outputs = {
        "Step": "Step",
        "CycleDone": "CycleDone",
        "ErrorLatched": "ErrorLatched",
        "ErrorCode": "ErrorCode",
        "GroupErrorID": "GroupError.GroupErrorID",
        "Powered": "Power.Status",
        "Enable": "Inputs.Enable",
        "PowerOn": "PowerOn",
        "CommLost": "Inputs.CommLost",
        "Cycles": "Cycles",
        "Requested": "Inputs.Requested",
    }
    r.append(
        Rung(
            "Write outputs: the robot's request, PLC_OUT, the alarms",
            block=Block("CellOutputs", "Outputs", inputs=outputs, in_outs={"Robot": "Robot"}),
        )
    )
    return r


def project() -> bytes:
    text = PROGRAM + INPUTS + OUTPUTS + CONFIGURATION
    unit = parse_text(SOURCE, text)
    drawing = Drawing()
    for rung in rungs():
        drawing.rung(rung)
    program = unit.pous[0]
    program.xml = pou = drawing.ld.makeelement(q("pou"), name=program.name, pouType="program")
    body = pou.makeelement(q("body"), {})
    pou.append(body)
    body.append(drawing.ld)
    return export([unit], {SOURCE: text}, name="plc-robot-ld", when=WHEN)


def main(argv: list[str]) -> int:
    data = project()
    if argv[1:] == ["--check"]:
        if OUT.read_bytes() != data:
            print(f"{OUT} is stale: run {Path(__file__).relative_to(ROOT)}", file=sys.stderr)
            return 1
        return 0
    OUT.write_bytes(data)
    print(f"wrote {OUT.relative_to(ROOT)} ({len(data)} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
