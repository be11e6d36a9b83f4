// Records what the dashboard costs the browser over a run: every requestAnimationFrame
// interval (the frame time a viewer sees), long tasks, and performance.memory.usedJSHeapSize
// every SAMPLE_S seconds. Nothing is forced (no GC from outside): the frame times are the
// page's own, and the retained-memory trend is read from the heap's post-GC floor.
//
// usage: node measure_frames.mjs PAGE_URL SECONDS [SAMPLE_S]
// prints: one JSON line {ok, frame_ms: [...], long_tasks_ms: [...], heap: [[t_s, bytes]...],
//         counts, worst_draw_ms}
import { openPage, runScenario } from "./browser.mjs";

const [pageUrl, secondsText, sampleText = "1"] = process.argv.slice(2);
const seconds = Number(secondsText);
const sampleS = Number(sampleText);

function installRecorder() {
  const recorder = { frameMs: [], longTasksMs: [] };
  let last = null;
  const tick = (now) => {
    if (last !== null) recorder.frameMs.push(now - last);
    last = now;
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
  new PerformanceObserver((list) => {
    for (const entry of list.getEntries()) recorder.longTasksMs.push(entry.duration);
  }).observe({ type: "longtask", buffered: false });
  window.frameRecorder = recorder;
}

await runScenario("measure_frames.mjs", (seconds + 120) * 1000, async () => {
  const { page, close } = await openPage(undefined, ["--enable-precise-memory-info"]);
  try {
    await page.goto(pageUrl);
    await page.waitForSelector("#connection.badge-on", { timeout: 30000 });
    await page.waitForFunction(() => window.riverbridgeDashboard?.counts["/lidar/points"] > 0,
      null, { timeout: 60000, polling: 250 });
    await page.evaluate(installRecorder);
    const heap = [];
    const started = Date.now();
    while (Date.now() - started < seconds * 1000) {
      const used = await page.evaluate(() => performance.memory.usedJSHeapSize);
      heap.push([(Date.now() - started) / 1000, used]);
      await page.waitForTimeout(Math.max(0, Math.min(sampleS * 1000, seconds * 1000 - (Date.now() - started))));
    }
    const recorded = await page.evaluate(() => ({
      frame_ms: window.frameRecorder.frameMs,
      long_tasks_ms: window.frameRecorder.longTasksMs,
      counts: window.riverbridgeDashboard.counts,
      worst_draw_ms: window.riverbridgeDashboard.frames.worstWorkMs,
      panel_worst_ms: window.riverbridgeDashboard.frames.panelWorstMs,
      handler_worst_ms: window.riverbridgeDashboard.handlerWorstMs,
    }));
    return { seconds, heap, ...recorded };
  } finally {
    await close();
  }
});
