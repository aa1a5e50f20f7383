// client.ts -- the typed API client: openapi-fetch over the types generated from the agent's
// OpenAPI document (schema.d.ts, `npm run gen-api`; tests/python/webui checks it is not stale).
// The browser signs in with its session cookie (HttpOnly: this code never sees it); every change
// carries the session's CSRF token, and requests made while the user is away are marked as the
// UI's own, so that polling pages do not keep a session alive past its idle timeout.
import createClient, { type Middleware } from "openapi-fetch";
import { type Place, placeIn } from "./place";
import type { paths } from "./schema";

export type Api = ReturnType<typeof createClient<paths>>;

/** An API error with the agent's message (`detail`) and, for a refused set, where in it (the place's fields). */
export class ApiError extends Error {
  constructor(
    readonly status: number,
    message: string,
    readonly place: Place = {},
  ) {
    super(message);
  }
}

export function detailOf(body: unknown): string {
  if (body && typeof body === "object" && "detail" in body) {
    const d = (body as { detail: unknown }).detail;
    if (typeof d === "string") return d;
    if (Array.isArray(d))
      return d.map((e) => (e && typeof e === "object" && "msg" in e ? String(e.msg) : String(e))).join("; ");
    return JSON.stringify(d);
  }
  return typeof body === "string" ? body : JSON.stringify(body);
}

export const CSRF_HEADER = "X-CSRF-Token";
export const BACKGROUND_HEADER = "X-Indurop-Background";
/** Without a key press or a click for this long, the UI's requests are its own, not the user's. */
export const AWAY_AFTER_MS = 60_000;

let lastInput = Date.now();

/** Counts key presses and clicks in `target` as the user's presence. */
export function watchPresence(target: EventTarget): void {
  for (const type of ["keydown", "pointerdown", "wheel"])
    target.addEventListener(type, () => {
      lastInput = Date.now();
    });
}

/** Whether the user has not touched the page for AWAY_AFTER_MS (`now` for tests). */
export function userAway(now = Date.now()): boolean {
  return now - lastInput > AWAY_AFTER_MS;
}

export function isChange(method: string): boolean {
  return !["GET", "HEAD", "OPTIONS"].includes(method.toUpperCase());
}

export interface ApiOptions {
  /** the session's CSRF token, sent with every change (POST, PUT, PATCH, DELETE) */
  csrf?: string;
  /** a bearer token instead of the session cookie (the first-run page's admin token) */
  token?: string;
  /** the agent's origin ("" = this page's) */
  base?: string;
  /** called when the agent answers 401 to a request of the session: it has ended */
  onSignedOut?: () => void;
}

/** The headers a request of the session carries besides its cookie. */
export function sessionHeaders(method: string, csrf: string | undefined, away = userAway()): Record<string, string> {
  const headers: Record<string, string> = {};
  if (csrf && isChange(method)) headers[CSRF_HEADER] = csrf;
  if (away) headers[BACKGROUND_HEADER] = "1";
  return headers;
}

/** A client of the agent's API: signed in by the session cookie, or by `token`. */
export function makeApi(options: ApiOptions = {}): Api {
  const api = createClient<paths>({ baseUrl: options.base ?? "", credentials: "same-origin" });
  const auth: Middleware = {
    onRequest({ request }) {
      if (options.token) request.headers.set("Authorization", `Bearer ${options.token}`);
      else for (const [k, v] of Object.entries(sessionHeaders(request.method, options.csrf))) request.headers.set(k, v);
      return request;
    },
    onResponse({ response }) {
      if (response.status === 401 && !options.token) options.onSignedOut?.();
      return response;
    },
  };
  api.use(auth);
  return api;
}

/** The data of an openapi-fetch answer, or an ApiError carrying the agent's message. */
export function unwrap<T>(r: { data?: T; error?: unknown; response: Response }): T {
  if (r.error !== undefined || !r.response.ok) {
    throw new ApiError(r.response.status, detailOf(r.error), placeIn(r.error));
  }
  return r.data as T;
}
