// cell.ts -- drives the PLC + robot cell through the API, as an operator would from the panel:
// power on and start the pick-and-place cycle in repeat mode (docs/plc-robot-cell.md).
import { api, expect } from "./fixtures";

async function write(path: string, value: number): Promise<void> {
  const r = await api(`/variables/${path}`, { method: "PUT", body: JSON.stringify({ value }), headers: { "Content-Type": "application/json" } }, "operator");
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

async function powerOnAndStart(): Promise<boolean> {
  // an earlier stall (a test stops irpd for seconds; a loaded machine starves the simulator) may
  // have left the robot or the PLC in error (lost communication, ErrorID 8): MC_Reset first, as an
  // operator would
  await write("PLC_ROBOT.PLC_IN.Enable", 0);
  await write("PLC_ROBOT.I0", 0);
  await write("PLC_ROBOT.PLC_IN.Reset", 0);
  await write("PLC_ROBOT.PLC_IN.Reset", 1);
  await expect.poll(() => read("PLC_ROBOT.PLC_OUT.Error"), { timeout: 20_000 }).toBe(0);
  await write("PLC_ROBOT.PLC_IN.Reset", 0);
  await write("PLC_ROBOT.PLC_IN.CycleMode", 1);
  await write("PLC_ROBOT.PLC_IN.Enable", 1);
  if (!(await reaches("PLC_ROBOT.PLC_OUT.Powered", 1))) return false;
  await write("PLC_ROBOT.I0", 1);
  return reaches("PLC_ROBOT.PLC_OUT.Running", 1);
}

/** Resets, enables the drives, sets repeat mode and gives a rising edge on I0 once powered: the
 * robot keeps moving.  Does nothing when the cycle already runs; tries three times. */
export async function startCell(): Promise<void> {
  for (let attempt = 0; attempt < 3; attempt++) {
    if ((await read("PLC_ROBOT.PLC_OUT.Running")) === 1) return;
    if (await powerOnAndStart()) return;
  }
  throw new Error(`the cell did not start: ErrorID ${await read("PLC_ROBOT.PLC_OUT.ErrorID")}, ` +
    `comm_lost ${await read("PLC_ROBOT.IO_STATUS.comm_lost[0]")}`);
}
