// robot.ts -- the robot page (placeholder until it is built).
import type { Page } from "../app/context";

export const robotPage: Page = (root) => {
  root.innerHTML = "<h2>robot</h2>";
  return () => {};
};
