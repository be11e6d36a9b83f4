// Opens the dashboard in headless Chromium and checks it as an operator would: it connects,
// every panel's pixels change while data flows, a held arrow key turns the vessel (heading from
// /odom as the page shows it), and a screenshot is saved.
//
// usage: node drive_dashboard.mjs PAGE_URL SCREENSHOT_PATH
// prints: one JSON line {ok, connected, counts, panels_changed, yaw_before_rad, yaw_after_rad, …}
import { openPage, runScenario } from "../../web/scripts/browser.mjs";

const [pageUrl, screenshotPath] = process.argv.slice(2);
const CANVASES = ["map", "camera", "radar", "imu", "latency"];
const LIVE_TOPICS = ["/lidar/points", "/camera/image/compressed", "/radar/image", "/imu/data",
  "/odom", "/nav/boxes", "/nav/lines", "/nav/obstacle_map"];
const STEER_MS = 3000;

/**
 * A cheap fingerprint of each canvas's pixels, compared between two moments: the page's panels
 * by id, plus the radar's polar raster alone (no caption, so only a new sweep changes it).
 */
function fingerprints(ids) {
  const fingerprint = (canvas) => {
    const data = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
    let sum = 0;
    let lit = 0;
    for (let i = 0; i < data.length; i += 4) {
      const value = data[i] + 2 * data[i + 1] + 3 * data[i + 2];
      sum = (sum * 31 + value * (i + 1)) % 2147483647;
      if (value > 400) lit += 1; // brighter than every background and grid line
    }
    return { sum, lit };
  };
  const prints = Object.fromEntries(ids.map((id) => [id, fingerprint(document.getElementById(id))]));
  prints.radar_raster = fingerprint(window.riverbridgeDashboard.panels.radar.raster);
  return prints;
}

/** What the LIDAR worker and the radar panel have received, and what the main connection took. */
function deliveryState() {
  const d = window.riverbridgeDashboard;
  return {
    worker_connected: d.lidar.connected,
    worker_errors: d.lidar.errors,
    received: d.counts["/lidar/points"],
    map_points: d.panels.map.pointCount,
    map_has_points_bitmap: d.panels.map.pointsBitmap !== null,
    main_connection_topics: d.connection.specs.map((spec) => spec.name),
    radar_sweeps: d.panels.radar.sweeps,
  };
}

async function waitForTopics(page, topics, timeoutMs) {
  await page.waitForFunction((names) => {
    const counts = window.riverbridgeDashboard?.counts;
    return counts && names.every((name) => counts[name] > 0);
  }, topics, { timeout: timeoutMs, polling: 250 });
}

/** Hold the left arrow; follow the heading from /odom as the page sees it, unwrapped. */
async function steer(page) {
  const yaw = () => page.evaluate(() => window.riverbridgeDashboard.vessel.yawRad);
  const before = await yaw();
  let turned = 0;
  let last = before;
  const follow = async () => {
    const now = await yaw();
    turned += Math.atan2(Math.sin(now - last), Math.cos(now - last));
    last = now;
  };
  await page.keyboard.down("ArrowLeft");
  const heldUntil = Date.now() + STEER_MS;
  while (Date.now() < heldUntil) {
    await page.waitForTimeout(100);
    await follow();
  }
  const during = await page.evaluate(() => window.riverbridgeDashboard.steering.command());
  await page.keyboard.up("ArrowLeft");
  await page.waitForTimeout(500);
  await follow();
  return { yaw_before_rad: before, yaw_after_rad: last, turned_rad: turned, command_while_held: during };
}

await runScenario("drive_dashboard.mjs", 150000, async () => {
  const { page, close } = await openPage();
  const errors = [];
  page.on("pageerror", (error) => errors.push(String(error)));
  try {
    await page.goto(pageUrl);
    await page.waitForSelector("#connection.badge-on", { timeout: 20000 });
    await waitForTopics(page, LIVE_TOPICS, 60000);
    await page.waitForSelector("#topics-table", { timeout: 10000 });
    const first = await page.evaluate(fingerprints, CANVASES);
    const deliveryFirst = await page.evaluate(deliveryState);
    const firstTopics = await page.locator("#topics").innerText();
    const steering = await steer(page);
    const second = await page.evaluate(fingerprints, CANVASES);
    const deliverySecond = await page.evaluate(deliveryState);
    const state = await page.evaluate(() => {
      const d = window.riverbridgeDashboard;
      return { counts: d.counts, frames: d.frames, trace: d.trace.medians(), ages: d.ages.medians() };
    });
    await page.screenshot({ path: screenshotPath });
    // the badge as it stands now, after steering: not the wait above, which throws instead
    const connected = await page.locator("#connection").evaluate((el) => el.classList.contains("badge-on"));
    return {
      connected,
      ...state,
      ...steering,
      first,
      second,
      panels_changed: Object.fromEntries(CANVASES.map((id) => [id, first[id].sum !== second[id].sum])),
      radar_raster_changed: first.radar_raster.sum !== second.radar_raster.sum,
      delivery_first: deliveryFirst,
      delivery_second: deliverySecond,
      topics_text: await page.locator("#topics").innerText(),
      topics_titles: await page.locator("#topics tr[title]").evaluateAll(
        (rows) => rows.map((row) => row.title)),
      first_topics_text: firstTopics,
      page_errors: errors,
    };
  } finally {
    await close();
  }
});
