// cell.ts -- drives the PLC + robot cell through the API, as an operator would from the panel:
// power on and start the pick-and-place cycle in repeat mode (docs/plc-robot-cell.md).
import { api, expect } from "./fixtures";

async function write(path: string, value: number): Promise<void> {
  const r = await api(`/variables/${path}`, { method: "PUT", body: JSON.stringify({ value }), headers: { "Content-Type": "application/json" } }, "operator");
  expect(r.status, await r.clone().text()).toBe(200);
}

/** Enables the drives, sets repeat mode, gives a rising edge on I0: the robot keeps moving. */
export async function startCell(): Promise<void> {
  await write("PLC_ROBOT.PLC_IN.CycleMode", 1);
  await write("PLC_ROBOT.PLC_IN.Enable", 1);
  await write("PLC_ROBOT.I0", 0);
  await new Promise((r) => setTimeout(r, 300));
  await write("PLC_ROBOT.I0", 1);
  await expect.poll(async () => (await (await api("/variables/PLC_ROBOT.PLC_OUT.Running")).json()).value, { timeout: 20_000 }).toBe(1);
}
