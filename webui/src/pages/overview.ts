// overview.ts -- the overview page (placeholder until it is built).
import type { Page } from "../app/context";

export const overviewPage: Page = (root) => {
  root.innerHTML = "<h2>overview</h2>";
  return () => {};
};
