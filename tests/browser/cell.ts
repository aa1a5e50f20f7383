// cell.ts -- drives the PLC + robot cell through the API, as an operator would from the panel:
// power on and start the pick-and-place cycle in repeat mode (docs/plc-robot-cell.md).
import { api, expect } from "./fixtures";

async function write(path: string, value: number): Promise<void> {
  const r = await api(
    `/variables/${path}`,
    { method: "PUT", body: JSON.stringify({ value }), headers: { "Content-Type": "application/json" } },
    "operator",
  );
  expect(r.status, await r.clone().text()).toBe(200);
}

async function read(path: string): Promise<number> {
  return (await (await api(`/variables/${path}`)).json()).value;
}

/** Whether `path` reads `value` within 10 s (polled every 100 ms). */
async function reaches(path: string, value: number): Promise<boolean> {
  for (let i = 0; i < 100; i++) {
    if ((await read(path)) === value) return true;
    await new Promise((r) => setTimeout(r, 100));
  }
  return (await read(path)) === value;
}

/** A rising edge on Reset (MC_Reset) with the drives off; whether the PLC then reports no error. */
async function resetOnce(): Promise<boolean> {
  await write("PLC_ROBOT.PLC_IN.Enable", 0);
  await write("PLC_ROBOT.PLC_IN.Reset", 0);
  await write("PLC_ROBOT.PLC_IN.Reset", 1);
  const cleared = await reaches("PLC_ROBOT.PLC_OUT.Error", 0);
  await write("PLC_ROBOT.PLC_IN.Reset", 0);
  return cleared;
}

async function powerOnAndStart(): Promise<boolean> {
  // an earlier stall (a test stops irpd for seconds; a loaded machine starves the simulator) may
  // have left the robot or the PLC in error (lost communication, ErrorID 8): MC_Reset first, as an
  // operator would.  The browser's software rendering can starve the simulator again right after
  // the reset (a drive fault or lost communication once more, seen in CI): the next attempt gives a
  // new rising edge, as an operator presses Reset again.
  await write("PLC_ROBOT.I0", 0);
  if (!(await resetOnce())) return false;
  await write("PLC_ROBOT.PLC_IN.CycleMode", 1);
  await write("PLC_ROBOT.PLC_IN.Enable", 1);
  if (!(await reaches("PLC_ROBOT.PLC_OUT.Powered", 1))) return false;
  await write("PLC_ROBOT.I0", 1);
  return reaches("PLC_ROBOT.PLC_OUT.Running", 1);
}

/** Leaves the cell able to power its drives, powered off: what an earlier stall left (alarms.spec
 * stops irpd for seconds: the drives fault on lost communication) cleared by Reset, then the drives
 * powered once and off again, as an operator checks; tries three times. */
export async function readyToPower(): Promise<void> {
  for (let attempt = 0; attempt < 3; attempt++) {
    if (!(await resetOnce())) continue;
    await write("PLC_ROBOT.PLC_IN.Enable", 1);
    const powered = await reaches("PLC_ROBOT.PLC_OUT.Powered", 1);
    await write("PLC_ROBOT.PLC_IN.Enable", 0);
    if (powered && (await reaches("PLC_ROBOT.PLC_OUT.Powered", 0))) return;
  }
  throw new Error(
    `the cell did not power its drives after 3 resets: ErrorID ${await read("PLC_ROBOT.PLC_OUT.ErrorID")}`,
  );
}

/** Resets, enables the drives, sets repeat mode and gives a rising edge on I0 once powered: the
 * robot keeps moving.  Does nothing when the cycle already runs; tries three times. */
export async function startCell(): Promise<void> {
  for (let attempt = 0; attempt < 3; attempt++) {
    if ((await read("PLC_ROBOT.PLC_OUT.Running")) === 1) return;
    if (await powerOnAndStart()) return;
  }
  const state = await Promise.all(
    [
      "PLC_OUT.Error",
      "PLC_OUT.ErrorID",
      "ROBOT_MODULE_STATE.ErrorID",
      "ROBOT_MODULE_STATE.eState",
      "PLC_OUT.Powered",
      "IO_STATUS.comm_lost[0]",
    ].map(async (v) => `${v} ${await read(`PLC_ROBOT.${v}`)}`),
  );
  throw new Error(`the cell did not start after 3 attempts: ${state.join(", ")}`);
}
