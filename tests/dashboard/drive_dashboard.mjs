// Opens the dashboard in headless Chromium and checks it as an operator would: it connects,
// every panel's pixels change while data flows, a held arrow key turns the vessel (heading from
// /odom as the page shows it), and a screenshot is saved.
//
// usage: node drive_dashboard.mjs PAGE_URL SCREENSHOT_PATH
// prints: one JSON line {ok, connected, counts, panels_changed, yaw_before_rad, yaw_after_rad, …}
import { openPage, runScenario } from "../../web/scripts/browser.mjs";

const [pageUrl, screenshotPath] = process.argv.slice(2);
const CANVASES = ["map", "camera", "imu", "latency"];
const LIVE_TOPICS = ["/lidar/points", "/camera/image/compressed", "/imu/data", "/odom",
  "/nav/boxes", "/nav/lines", "/nav/obstacle_map"];
const STEER_MS = 3000;

/** A cheap fingerprint of each canvas's pixels (sampled sums), compared between two moments. */
function fingerprints(ids) {
  return Object.fromEntries(ids.map((id) => {
    const canvas = document.getElementById(id);
    const data = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
    let sum = 0;
    let lit = 0;
    for (let i = 0; i < data.length; i += 4) {
      const value = data[i] + 2 * data[i + 1] + 3 * data[i + 2];
      sum = (sum * 31 + value * (i + 1)) % 2147483647;
      if (value > 400) lit += 1; // brighter than every background and grid line
    }
    return [id, { sum, lit }];
  }));
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
    const firstTopics = await page.locator("#topics").innerText();
    const steering = await steer(page);
    const second = await page.evaluate(fingerprints, CANVASES);
    const state = await page.evaluate(() => {
      const d = window.riverbridgeDashboard;
      return { counts: d.counts, frames: d.frames, trace: d.trace.medians(), ages: d.ages.medians() };
    });
    await page.screenshot({ path: screenshotPath });
    return {
      connected: true,
      ...state,
      ...steering,
      first,
      second,
      panels_changed: Object.fromEntries(CANVASES.map((id) => [id, first[id].sum !== second[id].sum])),
      topics_text: await page.locator("#topics").innerText(),
      first_topics_text: firstTopics,
      page_errors: errors,
    };
  } finally {
    await close();
  }
});
