// csv.ts -- the samples of a plot's visible window as CSV: seq, due time (s, CLOCK_MONOTONIC) and
// one column per variable, exactly as received (no resampling).
import type { SampleRing } from "./ring";

function field(s: string): string {
  return /[",\n\r]/.test(s) ? `"${s.replace(/"/g, '""')}"` : s;
}

function num(v: number): string {
  return Number.isNaN(v) ? "" : String(v);
}

/** The CSV of the samples with t0 ≤ t ≤ t1, in parts (join them, or hand them to a Blob). */
export function windowCsv(ring: SampleRing, paths: readonly string[], t0: number, t1: number): string[] {
  const [i0, i1] = ring.range(t0, t1);
  const parts: string[] = [["seq", "t", ...paths].map(field).join(",") + "\n"];
  const chunk: string[] = [];
  for (let i = i0; i < i1; i++) {
    const p = ring.slot(i);
    let row = `${ring.seq[p]},${ring.t[p].toFixed(9)}`;
    for (let c = 0; c < paths.length; c++) row += "," + num(ring.cols[c][p]);
    chunk.push(row);
    if (chunk.length === 4096) {
      parts.push(chunk.join("\n") + "\n");
      chunk.length = 0;
    }
  }
  if (chunk.length) parts.push(chunk.join("\n") + "\n");
  return parts;
}

/** Offers `parts` as a download named `name`. */
export function download(name: string, parts: string[]): void {
  const url = URL.createObjectURL(new Blob(parts, { type: "text/csv" }));
  const a = document.createElement("a");
  a.href = url;
  a.download = name;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10_000);
}
