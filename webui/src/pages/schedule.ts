// schedule.ts -- the schedule page (placeholder until it is built).
import type { Page } from "../app/context";

export const schedulePage: Page = (root) => {
  root.innerHTML = "<h2>schedule</h2>";
  return () => {};
};
