// What uPlot needs of a browser and jsdom lacks: matchMedia, Path2D (it draws with it) and
// ResizeObserver (the plot panel watches its size).  Imported first by the tests that make charts,
// so that it runs before uPlot is loaded.
window.matchMedia = ((query: string) => ({
  matches: false,
  media: query,
  addEventListener() {},
  removeEventListener() {},
})) as unknown as typeof window.matchMedia;
(globalThis as { Path2D?: unknown }).Path2D = class {
  moveTo() {}
  lineTo() {}
  rect() {}
  arc() {}
  closePath() {}
  bezierCurveTo() {}
};
(globalThis as { ResizeObserver?: unknown }).ResizeObserver ??= class {
  observe() {}
  disconnect() {}
};
