// robot.test.ts -- the robot page's data handling: joint positions from variables (value · scale +
// offset, as the agent's view), rad/deg and limits, the readouts table fed with samples, and the
// joint map editor's form read back into PUT /robot/joints' body.
import { describe, expect, it } from "vitest";
import { degrees, jointPosition, limitsText, outsideLimits, type RobotJoint } from "../../../src/robot/format";
import { jointMapForm, readJointMap } from "../../../src/robot/jointmap";
import { JointReadouts } from "../../../src/robot/readouts";

const J1: RobotJoint = {
  joint: "joint_1",
  variable: "C.q[0]",
  scale: 2,
  offset: 0.5,
  type: "revolute",
  lower: -2.967,
  upper: 2.967,
};
const J2: RobotJoint = {
  joint: "joint_2",
  variable: null,
  scale: 1,
  offset: 0,
  type: "revolute",
  lower: -1.745,
  upper: 2.356,
};
const SLIDE: RobotJoint = {
  joint: "slide",
  variable: "C.x",
  scale: 1,
  offset: 0,
  type: "prismatic",
  lower: 0,
  upper: 0.5,
};

describe("format", () => {
  it("computes a joint's position as the agent does and holds unmapped joints at 0", () => {
    expect(jointPosition(J1, 0.25)).toBe(1);
    expect(jointPosition(J2, 3)).toBe(0);
    expect(jointPosition(J1, undefined)).toBe(0);
  });
  it("shows limits in degrees, metres for prismatic joints, none for continuous ones", () => {
    expect(degrees(Math.PI)).toBe(180);
    expect(limitsText(J1)).toBe("-170.0° … 170.0°");
    expect(limitsText(SLIDE)).toBe("0.000 … 0.500 m");
    expect(limitsText({ ...J1, type: "continuous", lower: null, upper: null })).toBe("none");
    expect(outsideLimits(J1, 3)).toBe(true);
    expect(outsideLimits(J1, 2.9)).toBe(false);
  });
});

describe("readouts", () => {
  it("has one row per joint and shows the newest values in rad and degrees", () => {
    const r = new JointReadouts([J1, J2, SLIDE]);
    expect(r.el.dataset.testid).toBe("joint-readouts");
    expect(r.variables()).toEqual(["C.q[0]", "C.x"]);
    const rows = r.el.querySelectorAll<HTMLElement>("[data-testid=joint-row]");
    expect([...rows].map((x) => x.dataset.joint)).toEqual(["joint_1", "joint_2", "slide"]);
    expect(rows[1].textContent).toContain("held at 0");
    r.update(
      new Map([
        ["C.q[0]", 0.25],
        ["C.x", 0.125],
      ]),
    );
    expect(rows[0].querySelector("[data-testid=joint-rad]")!.textContent).toBe("1.0000");
    expect(rows[0].querySelector("[data-testid=joint-deg]")!.textContent).toBe("57.30");
    expect(rows[2].querySelector("[data-testid=joint-rad]")!.textContent).toBe("0.1250 m");
    expect(rows[2].querySelector("[data-testid=joint-deg]")!.textContent).toBe("—");
    r.update(new Map([["C.q[0]", 2]]));
    expect(rows[0].classList.contains("bad")).toBe(true); // 4.5 rad: outside the limits
  });
  it("escapes names it did not make", () => {
    const r = new JointReadouts([{ ...J1, joint: "<img src=x onerror=alert(1)>" }]);
    expect(r.el.querySelector("img")).toBeNull();
  });
});

describe("joint map editor", () => {
  it("reads the form back as the body of PUT /robot/joints", () => {
    const form = jointMapForm([J1, J2], ["C.q[0]", "C.q[1]"]);
    expect(form.querySelectorAll("datalist option").length).toBe(2);
    const rows = form.querySelectorAll<HTMLElement>("tr[data-joint]");
    rows[1].querySelector<HTMLInputElement>("input[name=variable]")!.value = " C.q[1] ";
    rows[1].querySelector<HTMLInputElement>("input[name=offset]")!.value = "-0.1";
    rows[0].querySelector<HTMLInputElement>("input[name=variable]")!.value = "";
    expect(readJointMap(form)).toEqual({
      joints: [
        { joint: "joint_1", variable: null, scale: 2, offset: 0.5 },
        { joint: "joint_2", variable: "C.q[1]", scale: 1, offset: -0.1 },
      ],
    });
  });
  it("names the joint whose scale or offset is not a number", () => {
    const form = jointMapForm([J1, J2], []);
    form
      .querySelectorAll<HTMLElement>("tr[data-joint]")[1]
      .querySelector<HTMLInputElement>("input[name=scale]")!.value = "two";
    expect(readJointMap(form)).toEqual({ error: 'joint_2: the scale "two" is not a number' });
  });
});
