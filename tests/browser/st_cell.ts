// st_cell.ts -- the cell whose PLC is written in Structured Text (config/sets/plc-robot-st) on a server
// of a spec's own: its built folder stored and activated through the API, and API calls with the
// admin token of that server (programs.spec.ts, monitor.spec.ts).
import { readdirSync, readFileSync, statSync } from "node:fs";
import { join, relative } from "node:path";
import { expect } from "./fixtures";
import { ROOT, type Role, type Server } from "./server";

export const BUILT = join(ROOT, "build/sets/plc-robot-st");
export const MAIN = join(ROOT, "config/sets/plc-robot-st/main.st");

/** Every file under `dir`. */
export function files(dir: string): string[] {
  return readdirSync(dir).flatMap((n) => {
    const p = join(dir, n);
    return statSync(p).isDirectory() ? files(p) : [p];
  });
}

export async function rest(s: Server, path: string, init: RequestInit = {}, role: Role = "admin"): Promise<Response> {
  const headers = new Headers(init.headers);
  headers.set("Authorization", `Bearer ${s.tokens[role]}`);
  return fetch(`${s.url}/api/v1${path}`, { ...init, headers });
}

/** The ST cell as a stored, active set: the built folder as it is, which carries its sources, main.st
 * and the cell's cell.glb, beside what irpd runs (stc lays the set out again from them, docs/st.md
 * "Uploading ST"). */
export async function storeTheCell(s: Server): Promise<string> {
  const form = new FormData();
  for (const p of files(BUILT)) form.append("files", new Blob([readFileSync(p)]), relative(BUILT, p));
  return storeAndActivate(s, form);
}

/** Uploads the files of `form` as a set (the appliance builds it), activates it; its id. */
export async function storeAndActivate(s: Server, form: FormData): Promise<string> {
  const r = await rest(s, "/sets", { method: "POST", body: form });
  expect(r.status, await r.clone().text()).toBe(201);
  const id = (await r.json()).id as string;
  const a = await rest(s, `/sets/${id}/activate`, {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ mode: "auto" }),
  });
  expect(a.status, await a.clone().text()).toBe(200);
  return id;
}
