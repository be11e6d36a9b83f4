// Headless Debian Chromium driven by playwright-core (installed in web/node_modules by
// `npm ci --prefix web`); never a downloaded browser build.
import { createRequire } from "node:module";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

const require = createRequire(new URL("../package.json", import.meta.url));
const { chromium } = require("playwright-core");

export const CHROMIUM = process.env.RIVERBRIDGE_CHROMIUM ?? "/usr/bin/chromium";
// Without the background-networking flags Chromium keeps calling Google's hosts, which this
// machine's closed network refuses (machine notes).
const FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync"];

/** A page of a fresh headless Chromium profile; call `close()` when done. */
export async function openPage(viewport = { width: 1600, height: 900 }, extraArgs = []) {
  const profile = mkdtempSync(join(tmpdir(), "riverbridge-chromium-"));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM, headless: true, args: [...FLAGS, ...extraArgs], viewport,
  });
  const page = context.pages()[0] ?? (await context.newPage());
  const close = async () => {
    await context.close();
    rmSync(profile, { recursive: true, force: true });
  };
  return { page, close };
}

/** Run `body` and print its result as one JSON line; print {ok:false} and exit 1 on error. */
export async function runScenario(name, timeoutMs, body) {
  const timer = setTimeout(() => finish(1, { ok: false, reason: `${name}: timeout after ${timeoutMs} ms` }), timeoutMs);
  try {
    const result = await body();
    clearTimeout(timer);
    finish(0, { ok: true, ...result });
  } catch (error) {
    finish(1, { ok: false, reason: `${name}: ${error?.stack ?? error}` });
  }
}

function finish(code, result) {
  // exit only once the line is flushed: a pipe takes large writes asynchronously
  process.stdout.write(`${JSON.stringify(result)}\n`, () => process.exit(code));
}
