// Builds the dashboard into web/dist/, which the bridge serves at http://HOST:PORT/.
// Asset names carry a content hash, so the bridge can let browsers cache them for good.
import { defineConfig } from "vite";

export default defineConfig({
  base: "./",
  build: {
    outDir: "dist",
    emptyOutDir: true,
    target: "es2022",
    chunkSizeWarningLimit: 1024,
  },
});
