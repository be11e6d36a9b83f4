// roslibjs provides a std_srvs/srv/SetBool service and serves CALLS requests: `data: true`
// succeeds, `data: false` fails. MODE "async" uses `advertiseAsync` (a failure throws, and
// roslibjs answers result:false with the error text as values); MODE "sync" uses
// `advertise` (a failure returns false, and roslibjs answers result:false with no values).
//
// usage: node provide_service.mjs URL SERVICE CALLS MODE
// prints: {ok, requests: [args…]} after CALLS requests were answered.
import { Service } from "roslib";
import { connect, scenario, succeed, watchStatus } from "./common.mjs";

const [url, serviceName, callsText, mode] = scenario("provide_service.mjs", ["URL", "SERVICE", "CALLS", "MODE"]);
// Give the last response time to leave the socket before the process exits.
const FLUSH_DELAY_MS = 500;

const ros = await connect(url);
const statusOps = watchStatus(ros);
const requests = [];
const service = new Service({ ros, name: serviceName, serviceType: "std_srvs/srv/SetBool" });
function noteRequest(request) {
  requests.push(request);
  if (requests.length >= Number(callsText)) {
    setTimeout(() => succeed({ requests, status_ops: statusOps }), FLUSH_DELAY_MS);
  }
}

if (mode === "async") {
  await service.advertiseAsync(async (request) => {
    noteRequest(request);
    if (!request.data) {
      throw new Error("refusing to open the lock gate");
    }
    return { success: true, message: "lock gate opening" };
  });
} else {
  await service.advertise((request, response) => {
    noteRequest(request);
    if (!request.data) {
      return false;
    }
    response.success = true;
    response.message = "lock gate opening";
    return true;
  });
}
