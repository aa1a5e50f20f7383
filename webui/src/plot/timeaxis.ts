// timeaxis.ts -- the x scale of a uPlot chart whose x values are wall-clock times (Unix seconds).

/** The x-range of samples taken at wall-clock `times` (Unix s, ascending): from the first to the
 * newest, at least `minSpan` seconds wide and ending at the newest (null while there is none).
 * uPlot's own range for a single time point is 86 400 / ms wide: 1000 days with x in seconds, an
 * axis labelled in months. */
export function wallClockRange(times: readonly number[], minSpan: number): [number | null, number | null] {
  if (!times.length) return [null, null];
  const newest = times[times.length - 1];
  return [Math.min(times[0], newest - minSpan), newest];
}
