// modules.ts -- the modules page (placeholder until it is built).
import type { Page } from "../app/context";

export const modulesPage: Page = (root) => {
  root.innerHTML = "<h2>modules</h2>";
  return () => {};
};
