// roslibjs serves the ROS 2 action example_interfaces/action/Fibonacci (roslib `Action`):
// feedback after every new element, then setSucceeded; a negative order is setFailed; an
// order above LONG_ORDER stays open until cancelled, then setCanceled.
//
// usage: node action_server.mjs URL ACTION GOALS
// prints: {ok, goals: [args…]} after GOALS goals were finished.
import { Action } from "roslib";
import { connect, scenario, succeed, watchStatus } from "./common.mjs";

const [url, actionName, goalsText] = scenario("action_server.mjs", ["URL", "ACTION", "GOALS"]);
// Give the last result time to leave the socket before the process exits.
const FLUSH_DELAY_MS = 500;
const LONG_ORDER = 1000;

const ros = await connect(url);
const statusOps = watchStatus(ros);
const goals = [];
const action = new Action({ ros, name: actionName, actionType: "example_interfaces/action/Fibonacci" });

let finished = 0;
function finishGoal() {
  finished += 1;
  if (finished >= Number(goalsText)) {
    setTimeout(() => succeed({ goals, status_ops: statusOps }), FLUSH_DELAY_MS);
  }
}

const open = new Map();

function onCancel(goalId) {
  if (open.has(goalId)) {
    action.setCanceled(goalId, { sequence: open.get(goalId) });
    open.delete(goalId);
    finishGoal();
  }
}

action.advertise((goal, goalId) => {
  goals.push(goal);
  if (goal.order > LONG_ORDER) {
    open.set(goalId, [0, 1]);
    action.sendFeedback(goalId, { sequence: [0, 1] });
    return;
  }
  if (goal.order < 0) {
    action.setFailed(goalId);
    finishGoal();
    return;
  }
  const sequence = [0, 1];
  for (let index = 1; index < goal.order; index++) {
    sequence.push(sequence[index] + sequence[index - 1]);
    action.sendFeedback(goalId, { sequence: [...sequence] });
  }
  action.setSucceeded(goalId, { sequence });
  finishGoal();
}, onCancel);
