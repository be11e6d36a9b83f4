"""roslibpy (PyPI) as a user's client on host A of the two-host test, run in A's namespace.

usage:
  python3 roslibpy_host.py HOST PORT publish TOPIC SECONDS
      advertise TOPIC as std_msgs/msg/String and publish "hello from A <n>" at 10 Hz.
  python3 roslibpy_host.py HOST PORT call SERVICE TIMEOUT_S
      call SERVICE (std_srvs/srv/SetBool, data: true) until it answers; print the answer.
Prints one JSON line; exit code 0 on success.
"""

from __future__ import annotations

import json
import sys
import time

import roslibpy


def publish(ros: roslibpy.Ros, topic_name: str, seconds: float) -> dict:
    topic = roslibpy.Topic(ros, topic_name, "std_msgs/msg/String")
    topic.advertise()
    sent = 0
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        topic.publish(roslibpy.Message({"data": f"hello from A {sent}"}))
        sent += 1
        time.sleep(0.1)
    return {"ok": True, "sent": sent}


def call(ros: roslibpy.Ros, service_name: str, timeout_s: float) -> dict:
    service = roslibpy.Service(ros, service_name, "std_srvs/srv/SetBool")
    deadline = time.monotonic() + timeout_s
    last_error = "never called"
    while time.monotonic() < deadline:
        try:
            answer = service.call(roslibpy.ServiceRequest({"data": True}), timeout=10)
            return {"ok": True, "response": dict(answer)}
        except Exception as exc:  # not discovered yet: "Service ... does not exist"
            last_error = str(exc)
            time.sleep(0.5)
    return {"ok": False, "reason": last_error}


def main(argv: list[str]) -> int:
    host, port, mode, name, seconds = argv
    ros = roslibpy.Ros(host=host, port=int(port))
    ros.run(timeout=60)
    try:
        result = (publish if mode == "publish" else call)(ros, name, float(seconds))
    finally:
        ros.close()
    print(json.dumps(result), flush=True)
    return 0 if result["ok"] else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
