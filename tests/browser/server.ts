// server.ts -- starts serve.py (real irpd + agent, tests/browser/serve.py) and stops it by pid.
import { spawn } from "node:child_process";
import { existsSync, mkdtempSync, readFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";

export type Role = "admin" | "operator" | "viewer";
/** a user the tests sign in with through the form */
export interface User {
  name: string;
  password: string;
}

export interface Server {
  url: string;
  /** for the tests' own API calls (checking what the UI did) */
  tokens: Record<Role, string>;
  /** one user per role, created with the admin token when the agent started */
  users: Record<Role, User>;
  work: string;
  /** indurop-opcua on the first agent's data folder (startServer's opcua option), else null */
  opcua: { url: string; data: string } | null;
  /** a second agent on the same irpd, with the meshcat 3D view */
  meshcat: { url: string; tokens: Record<Role, string>; users: Record<Role, User> };
  /** bridge: the cell's DDS bridge (browser-cell on the line); ghost: another controller's bridge, without an irpd */
  pids: { irpd: number; agent: number; agent_meshcat: number; bridge: number; ghost: number; serve: number };
}

export const ROOT = resolve(__dirname, "../..");
export const PYTHON = join(ROOT, ".venv/bin/python");

/** Starts irpd (config: a module.xml, default the PLC + robot cell) and its agents, and with
 * `opcua` indurop-opcua; resolves when up. */
export async function startServer(config?: string, opts: { opcua?: boolean } = {}): Promise<Server> {
  const out = join(mkdtempSync(join(tmpdir(), "indurop-serve-")), "server.json");
  const args = [join(__dirname, "serve.py"), out, ...(config ? [config] : []), ...(opts.opcua ? ["--opcua"] : [])];
  const child = spawn(PYTHON, args, { stdio: ["ignore", "inherit", "inherit"] });
  const deadline = Date.now() + 60_000;
  while (!existsSync(out)) {
    if (child.exitCode !== null) throw new Error(`serve.py ended with ${child.exitCode}`);
    if (Date.now() > deadline) throw new Error("irpd + agent did not come up within 60 s");
    await new Promise((r) => setTimeout(r, 100));
  }
  return JSON.parse(readFileSync(out, "utf8")) as Server;
}

/** SIGTERM to serve.py by pid; it stops the agent and irpd by theirs. */
export async function stopServer(s: Server): Promise<void> {
  try {
    process.kill(s.pids.serve, "SIGTERM");
  } catch {
    return;
  }
  for (let i = 0; i < 200; i++) {
    try {
      process.kill(s.pids.serve, 0);
    } catch {
      return;
    }
    await new Promise((r) => setTimeout(r, 100));
  }
  process.kill(s.pids.serve, "SIGKILL");
}
