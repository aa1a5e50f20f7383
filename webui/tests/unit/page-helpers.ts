// page-helpers.ts -- what the tests of a page mounted in a DOM share: letting its pending promises
// settle, and finding an element by its data-testid.

/** Lets the page's pending promises (its API answers, faked) settle. */
export const flush = async (): Promise<void> => {
  for (let i = 0; i < 10; i++) await Promise.resolve();
};

/** The element of `root` with this data-testid, or null. */
export const q = (root: HTMLElement, testid: string): HTMLElement | null =>
  root.querySelector<HTMLElement>(`[data-testid="${testid}"]`);

export interface Call {
  method: string;
  path: string;
  opts: Record<string, unknown>;
}

/** An API client's stand-in whose every request is noted in `calls` and answered 200 with what
 *  `reply` gives for it. */
export function fakeApi(reply: (path: string, opts: Record<string, unknown>) => unknown) {
  const calls: Call[] = [];
  const answer =
    (method: string) =>
    async (path: string, opts: Record<string, unknown> = {}) => {
      calls.push({ method, path, opts });
      return { data: reply(path, opts), response: new Response(null, { status: 200 }) };
    };
  return { calls, api: { GET: answer("GET"), POST: answer("POST"), PUT: answer("PUT"), DELETE: answer("DELETE") } };
}
