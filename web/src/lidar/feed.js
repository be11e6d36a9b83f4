// The page's side of the LIDAR worker (./worker.js): starts it, tells it the map's view, and
// hands each finished scan bitmap to `onCloud`. The page never sees the full PointCloud2.

/**
 * @param {object} options  {url, topic, messageType, throttleMs, maxPoints}
 * @param {(cloud: {bitmap: ImageBitmap | null, pointCount: number, sourcePoints: number,
 *   frameId: string, stampMs: number, ageMs: number, workMs: number, replot: boolean})
 *   => void} onCloud  replot: the last scan drawn again for a new view, not a new message
 * @returns {{connected: boolean, errors: string[], setView: (view: object) => void}}
 */
export function startLidarWorker(options, onCloud) {
  const worker = new Worker(new URL("./worker.js", import.meta.url), { type: "module" });
  const feed = {
    connected: false,
    errors: [],
    setView: (view) => worker.postMessage({ type: "view", view }),
  };
  worker.onmessage = ({ data }) => {
    if (data.type === "cloud") onCloud(data);
    else if (data.type === "state") feed.connected = data.connected;
  };
  // a worker's exceptions never reach the page's own error handlers: keep them visible
  worker.onerror = (event) => {
    feed.errors.push(String(event.message ?? event));
    console.error("LIDAR worker:", event.message ?? event);
  };
  worker.postMessage({ type: "start", ...options });
  return feed;
}
