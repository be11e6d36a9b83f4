// Builds the dashboard into web/dist/, which the bridge serves at http://HOST:PORT/.
// Asset names carry a content hash, so the bridge can let browsers cache them for good.
import { defineConfig } from "vite";

export default defineConfig({
  base: "./",
  // module workers: roslib loads its websocket transport with a dynamic import, which needs
  // code splitting, and Vite's default worker format (iife) cannot split
  worker: { format: "es" },
  build: {
    outDir: "dist",
    emptyOutDir: true,
    target: "es2022",
    chunkSizeWarningLimit: 1024,
  },
});
