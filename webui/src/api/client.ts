// client.ts -- the typed API client: openapi-fetch over the types generated from the agent's
// OpenAPI document (schema.d.ts, `npm run gen-api`; tests/python/webui checks it is not stale).
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

/** A client that sends `token` on every request; `base` is the agent's origin ("" = this page's). */
export function makeApi(token: string, base = ""): Api {
  const api = createClient<paths>({ baseUrl: base });
  const auth: Middleware = {
    onRequest({ request }) {
      request.headers.set("Authorization", `Bearer ${token}`);
      return request;
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
