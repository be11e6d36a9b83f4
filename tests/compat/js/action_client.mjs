// roslibjs as an action client (roslib `Action`): one goal to its end with its feedback, then
// a long goal cancelled after its first feedback.
//
// usage: node action_client.mjs URL ACTION ACTION_TYPE
// prints: {ok, result, feedback: [values…], canceled: "<roslib's failure text>"}
import { Action } from "roslib";
import { connect, fail, scenario, succeed } from "./common.mjs";

const [url, actionName, actionType] = scenario("action_client.mjs", ["URL", "ACTION", "ACTION_TYPE"]);
const LONG_ORDER = 40;

const ros = await connect(url);
const action = new Action({ ros, name: actionName, actionType });

function run(goal, onFeedback) {
  return new Promise((resolve, reject) => {
    const id = action.sendGoal(goal, resolve, (values) => onFeedback(values, id), reject);
  });
}

const feedback = [];
const result = await run({ order: 5 }, (values) => feedback.push(values));
let canceled = null;
let cancelSent = false;
try {
  await run({ order: LONG_ORDER }, (_values, id) => {
    if (!cancelSent) {
      cancelSent = true;
      action.cancelGoal(id);
    }
  });
  fail("the long goal succeeded although it was cancelled");
} catch (error) {
  canceled = String(error);
}
succeed({ result, feedback, canceled });
