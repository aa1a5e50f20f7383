// panel-link.ts -- plot panels named in the Variables page's address, so a view can be bookmarked,
// shared, or opened by a script (the plot benchmark does).
import type { PanelConfig } from "./panel";

/** Panels named in the page's address, `#/variables?plot=a,b;c` (panels split by ";", paths by
 * ","), a view that can be bookmarked or shared; null when the address names none. */
export function panelsFromHash(hash: string): PanelConfig[] | null {
  const q = hash.indexOf("?");
  if (q < 0) return null;
  const plot = new URLSearchParams(hash.slice(q + 1)).get("plot");
  if (!plot) return null;
  return plot.split(";").map((group) => ({
    paths: group
      .split(",")
      .map((p) => p.trim())
      .filter(Boolean),
    mode: "time" as const,
    windowS: 10,
    xy: [null, null] as [string | null, string | null],
  }));
}
