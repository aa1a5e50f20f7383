// jitter.ts -- the jitter page (placeholder until it is built).
import type { Page } from "../app/context";

export const jitterPage: Page = (root) => {
  root.innerHTML = "<h2>jitter</h2>";
  return () => {};
};
