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

/** Enables the drives, sets repeat mode, gives a rising edge on I0 once powered: the robot keeps
 * moving.  Does nothing when the cycle already runs. */
export async function startCell(): Promise<void> {
  if ((await read("PLC_ROBOT.PLC_OUT.Running")) === 1) return;
  if ((await read("PLC_ROBOT.PLC_OUT.Error")) === 1) {
    // an earlier stall of the machine looked like lost communication (ErrorID 8): MC_Reset
    await write("PLC_ROBOT.PLC_IN.Reset", 0);
    await write("PLC_ROBOT.PLC_IN.Reset", 1);
    await expect.poll(() => read("PLC_ROBOT.PLC_OUT.Error"), { timeout: 20_000 }).toBe(0);
    await write("PLC_ROBOT.PLC_IN.Reset", 0);
  }
  await write("PLC_ROBOT.PLC_IN.CycleMode", 1);
  await write("PLC_ROBOT.I0", 0);
  await write("PLC_ROBOT.PLC_IN.Enable", 1);
  await expect.poll(() => read("PLC_ROBOT.PLC_OUT.Powered"), { timeout: 20_000 }).toBe(1);
  await write("PLC_ROBOT.I0", 1);
  await expect.poll(() => read("PLC_ROBOT.PLC_OUT.Running"), { timeout: 20_000 }).toBe(1);
}
