// context.ts -- what every page gets: the API client, who is signed in, the sample stream, the
// alarm feed, the forces, and the page contract (mount into an element, give back a function that unmounts).
import type { Api } from "../api/client";
import type { StreamClient } from "../stream/stream";
import type { AlarmFeed } from "./alarm-feed";
import type { ForceFeed } from "./force-feed";

export type Role = "viewer" | "operator" | "admin";

/** Who is signed in (the session itself is the agent's, behind an HttpOnly cookie). */
export interface Session {
  name: string;
  role: Role;
  /** the session's CSRF token: the API client sends it with every change */
  csrf: string;
}

export interface AppContext {
  api: Api;
  session: Session;
  stream: StreamClient;
  /** the alarms, live (one WebSocket for the whole UI) */
  alarms: AlarmFeed;
  /** the forces irpd holds, polled once for the whole UI (the banner, the Forces page) */
  forces: ForceFeed;
  /** true when the signed-in role is at least `role` (viewer < operator < admin). */
  can(role: Role): boolean;
  /** shows a short message in the status bar (errors in red). */
  notify(message: string, kind?: "info" | "error"): void;
}

/** A page: draws itself into `root`, keeps itself live, and returns its cleanup. */
export type Page = (root: HTMLElement, ctx: AppContext) => () => void;

const RANK: Record<Role, number> = { viewer: 0, operator: 1, admin: 2 };
export function roleAtLeast(have: Role, need: Role): boolean {
  return RANK[have] >= RANK[need];
}
