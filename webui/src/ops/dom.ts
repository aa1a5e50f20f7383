// dom.ts -- small DOM helpers for the operations pages: building elements, escaping text,
// polling without overlap, and error messages people can act on.
import { ApiError } from "../api/client";
import { placeText } from "../api/place";

type Child = Node | string | number | null | undefined | false;

/** An element with attributes (data-testid="x" as "data-testid": "x"; on* as listeners) and children. */
export function h<K extends keyof HTMLElementTagNameMap>(
  tag: K,
  attrs: Record<string, string | number | boolean | null | undefined | EventListener> = {},
  ...children: (Child | Child[])[]
): HTMLElementTagNameMap[K] {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === null || v === undefined || v === false) continue;
    if (typeof v === "function") e.addEventListener(k.replace(/^on/, ""), v);
    else if (k === "class") e.className = String(v);
    else if (v === true) e.setAttribute(k, "");
    else e.setAttribute(k, String(v));
  }
  for (const c of children.flat())
    if (c !== null && c !== undefined && c !== false) e.append(typeof c === "number" ? String(c) : c);
  return e;
}

/** Sets text only when it changed (keeps selections and avoids layout work on every poll). */
export function setText(e: Element, text: string): void {
  if (e.textContent !== text) e.textContent = text;
}

/** Sets the class list only when it changed. */
export function setClass(e: Element, cls: string): void {
  if (e.getAttribute("class") !== cls) e.setAttribute("class", cls);
}

export interface Poller {
  stop(): void;
  /** runs now (after the running call, if any) instead of waiting for the timer */
  now(): void;
}

/**
 * Calls `fn` every `everyMs` after the previous call ended (never two at once), until stopped; with
 * `fromStart`, every `everyMs` from the previous call's start (at once when it took longer: a rate).
 * A throw is passed to `onError`; polling goes on, so pages recover by themselves.
 */
export function poll(
  fn: () => Promise<unknown>,
  everyMs: number,
  onError: (e: unknown) => void = () => {},
  fromStart = false,
): Poller {
  let stopped = false;
  let timer: ReturnType<typeof setTimeout> | null = null;
  let running = false;
  let again = false;
  const run = async () => {
    if (stopped) return;
    if (running) {
      again = true;
      return;
    }
    running = true;
    if (timer) clearTimeout(timer);
    timer = null;
    const started = performance.now();
    try {
      await fn();
    } catch (e) {
      if (!stopped) onError(e);
    } finally {
      running = false;
      if (!stopped) {
        if (again) {
          again = false;
          void run();
        } else timer = setTimeout(run, fromStart ? Math.max(0, everyMs - (performance.now() - started)) : everyMs);
      }
    }
  };
  void run();
  return {
    stop() {
      stopped = true;
      if (timer) clearTimeout(timer);
    },
    now() {
      void run();
    },
  };
}

/** Shows a file path with break opportunities after its slashes. */
export function setPath(e: Element, path: string): void {
  if (e.getAttribute("title") === path) return;
  e.setAttribute("title", path);
  e.replaceChildren(
    ...path.split(/(?<=\/)/).flatMap((part, i) => (i ? [document.createElement("wbr"), part] : [part])),
  );
}

/** One line saying what went wrong: the agent's message, or that it did not answer. */
export function errorText(e: unknown): string {
  if (e instanceof ApiError) {
    if (e.status === 503) return `irpd unreachable: ${e.message}`;
    if (e.status === 502 || e.status === 504) return `the agent did not answer (HTTP ${e.status} from the proxy)`;
    if (
      e.status >= 500 &&
      (!e.message || /^(undefined|null|\{\})$/.test(e.message) || /internal server error/i.test(e.message))
    )
      return `HTTP ${e.status}: the agent failed to answer this request`;
    const where = placeText(e.place);
    return `HTTP ${e.status}: ${where ? `${where}: ` : ""}${e.message}`;
  }
  if (e instanceof TypeError) return "the agent did not answer (network error)";
  if (e instanceof Error) return e.message;
  return String(e);
}
