// Where does the dashboard's main thread spend its time? Records a V8 CPU profile of the page
// (Chrome DevTools Protocol) for a while on a running stack and prints the functions with the
// most self time, plus the long tasks seen meanwhile. A tool for finding the next thing to move
// off the main thread; workers are not in this profile.
//
// usage: node profile_main.mjs PAGE_URL SECONDS [TOP]
// prints: one JSON line {ok, seconds, total_ms, top: [[function, url:line, self_ms]], long_tasks_ms}
import { openPage, runScenario } from "./browser.mjs";

const [pageUrl, secondsText, topText = "25"] = process.argv.slice(2);
const seconds = Number(secondsText);

/** Self time per function (ms) from a CDP Profiler.Profile, largest first. */
function selfTimes(profile) {
  const byId = new Map(profile.nodes.map((node) => [node.id, node]));
  const totals = new Map();
  const deltas = profile.timeDeltas;
  for (let i = 0; i < profile.samples.length; i++) {
    const { callFrame } = byId.get(profile.samples[i]);
    const url = callFrame.url.split("/").pop();
    const key = `${callFrame.functionName || "(anonymous)"}\t${url}:${callFrame.lineNumber + 1}`;
    totals.set(key, (totals.get(key) ?? 0) + (deltas[i + 1] ?? 0) / 1000);
  }
  return [...totals].sort((a, b) => b[1] - a[1]).map(([key, ms]) => [...key.split("\t"), ms]);
}

await runScenario("profile_main.mjs", (seconds + 120) * 1000, async () => {
  const { page, close } = await openPage();
  try {
    await page.goto(pageUrl);
    await page.waitForFunction(() => window.riverbridgeDashboard?.counts["/lidar/points"] > 0,
      null, { timeout: 60000, polling: 250 });
    await page.evaluate(() => {
      window.longTasksMs = [];
      new PerformanceObserver((list) => {
        for (const entry of list.getEntries()) window.longTasksMs.push(entry.duration);
      }).observe({ type: "longtask" });
    });
    const cdp = await page.context().newCDPSession(page);
    await cdp.send("Profiler.enable");
    await cdp.send("Profiler.setSamplingInterval", { interval: 200 });
    await cdp.send("Profiler.start");
    await page.waitForTimeout(seconds * 1000);
    const { profile } = await cdp.send("Profiler.stop");
    const times = selfTimes(profile);
    return {
      seconds,
      total_ms: times.reduce((sum, row) => sum + row[2], 0),
      top: times.slice(0, Number(topText)),
      long_tasks_ms: await page.evaluate(() => window.longTasksMs),
    };
  } finally {
    await close();
  }
});
