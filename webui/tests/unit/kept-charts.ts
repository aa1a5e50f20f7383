// kept-charts.ts -- uPlot as the pages use it, keeping every chart they make so that a test can look
// at its scales, data and series.  In a test file (vi.mock stays per file):
//   vi.mock("uplot", async (original) => (await import("./kept-charts")).keepCharts(original));
//   import { charts } from "./kept-charts";
import type uPlot from "uplot";

export const charts: uPlot[] = [];

export async function keepCharts(original: () => Promise<unknown>): Promise<{ default: typeof uPlot }> {
  const U = ((await original()) as { default: typeof uPlot }).default;
  class Kept extends U {
    constructor(...a: ConstructorParameters<typeof uPlot>) {
      super(...a);
      charts.push(this);
    }
  }
  return { default: Kept };
}
