// The topic catalogue (schemas/catalogue.py) from its copy web/src/catalogue.json, which
// `python3 scripts/catalogue_json.py` writes and tests/test_catalogue.py keeps equal. The page
// spells no topic name or type itself: it looks them up here by key.
import catalogue from "./catalogue.json";

const BY_KEY = new Map(catalogue.topics.map((t) => [t.key, Object.freeze(t)]));

/** name -> catalogue entry ({key, name, type, producer, role, summary, consumers, ...}) */
export const BY_NAME = new Map([...BY_KEY.values()].map((t) => [t.name, t]));

/** What this page subscribes to (consumers include "dashboard"), in catalogue order. */
export const DASHBOARD_TOPICS = [...BY_KEY.values()].filter((t) => t.consumers.includes("dashboard"));

/** What the stack's processes always stream: the topic list flags those nobody publishes. */
export const EXPECTED_TOPICS = [...BY_KEY.values()].filter((t) =>
  (t.producer === "simulator" || t.producer === "navigation") && !t.latched && !t.enabled_by);

/** The catalogue entry of `key`; throws on a key the catalogue lacks (a typo fails at once). */
export function topic(key) {
  const entry = BY_KEY.get(key);
  if (!entry) throw new Error(`no topic "${key}" in the catalogue (schemas/catalogue.py)`);
  return entry;
}
