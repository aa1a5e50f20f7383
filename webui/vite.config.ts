// vite.config.ts -- builds the UI into dist/ (served by indurop-agent at /); every asset is bundled,
// nothing is loaded from a CDN.  `npm run dev` proxies the API to an agent on 127.0.0.1:8080.
import { defineConfig } from "vite";

export default defineConfig({
  base: "./",
  build: { outDir: "dist", assetsInlineLimit: 0, sourcemap: true, chunkSizeWarningLimit: 1500 },
  server: {
    proxy: { "/api": { target: process.env.INDUROP_URL ?? "http://127.0.0.1:8080", ws: true } },
  },
  test: { environment: "jsdom", include: ["tests/unit/**/*.test.ts"] },
});
