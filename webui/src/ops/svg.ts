// svg.ts -- building SVG elements (the schedule's timeline, the live view of LD/FBD/SFC diagrams).

const NS = "http://www.w3.org/2000/svg";

/** An SVG element with attributes and, optionally, its text. */
export function svgEl<K extends keyof SVGElementTagNameMap>(
  tag: K,
  attrs: Record<string, string | number>,
  text?: string,
): SVGElementTagNameMap[K] {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  if (text !== undefined) e.textContent = text;
  return e;
}
