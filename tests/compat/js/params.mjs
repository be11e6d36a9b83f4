// roslibjs Param set / get / getParams / delete through the bridge's rosapi parameters.
//
// usage: node params.mjs URL NAME VALUE_JSON
// prints: {ok, got, names, deleted}
import { Param } from "roslib";
import { connect, scenario, succeed, watchStatus } from "./common.mjs";

const [url, name, valueJson] = scenario("params.mjs", ["URL", "NAME", "VALUE_JSON"]);

function promised(start) {
  return new Promise((resolve, reject) => start(resolve, (error) => reject(new Error(String(error)))));
}

const ros = await connect(url);
const statusOps = watchStatus(ros);
const param = new Param({ ros, name });
await promised((ok, err) => param.set(JSON.parse(valueJson), ok, err));
const got = await promised((ok, err) => param.get(ok, err));
const names = await promised((ok, err) => ros.getParams(ok, err));
await promised((ok, err) => param.delete(ok, err));
const namesAfterDelete = await promised((ok, err) => ros.getParams(ok, err));
succeed({ got, names, names_after_delete: namesAfterDelete, status_ops: statusOps });
