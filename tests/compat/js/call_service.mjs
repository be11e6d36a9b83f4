// roslibjs calls a service once and reports which callback fired and with what.
//
// usage: node call_service.mjs URL SERVICE ARGS_JSON
// prints: {ok, outcome: "success" | "failure", values}
import { Service } from "roslib";
import { connect, scenario, succeed, watchStatus } from "./common.mjs";

const [url, serviceName, argsJson] = scenario("call_service.mjs", ["URL", "SERVICE", "ARGS_JSON"]);

const ros = await connect(url);
const statusOps = watchStatus(ros);
const service = new Service({ ros, name: serviceName });
service.callService(
  JSON.parse(argsJson),
  (values) => succeed({ outcome: "success", values, status_ops: statusOps }),
  (values) => succeed({ outcome: "failure", values, status_ops: statusOps }),
);
