// variables.ts -- the variables page (placeholder until it is built).
import type { Page } from "../app/context";

export const variablesPage: Page = (root) => {
  root.innerHTML = "<h2>variables</h2>";
  return () => {};
};
