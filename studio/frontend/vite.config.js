// Builds the pages into the package (flatland_ma/studio/static), which ships them as data.
import { defineConfig } from "vite";

export default defineConfig({
  base: "/",
  build: {
    outDir: "../../flatland_ma/studio/static",
    emptyOutDir: true,
    assetsDir: "assets",
    chunkSizeWarningLimit: 1500,
  },
});
