// roslibjs authenticates with rosauth's auth op, then calls /rosapi/get_time.
//
// usage: node auth.mjs URL MAC CLIENT DEST RAND T LEVEL END
// prints: {ok, outcome: "success" | "failure" | "closed", values?}
import { Service } from "roslib";
import { connect, scenario, succeed } from "./common.mjs";

const [url, mac, client, dest, rand, t, level, end] = scenario("auth.mjs", [
  "URL", "MAC", "CLIENT", "DEST", "RAND", "T", "LEVEL", "END",
]);

const ros = await connect(url);
ros.on("close", () => succeed({ outcome: "closed" }));
ros.authenticate(mac, client, dest, rand, Number(t), level, Number(end));
const service = new Service({ ros, name: "/rosapi/get_time" });
service.callService(
  {},
  (values) => succeed({ outcome: "success", values }),
  (values) => succeed({ outcome: "failure", values }),
);
