"""A real ROS 2 node (rclpy from PyPI's ros-<distro>-rclpy wheels, rmw_fastrtps_cpp) that the
DDS tests meet through the bridge. Runs under the ROS 2 venv's Python 3.12, never imported by
the project's own interpreter.

usage: python3.12 rclpy_node.py NODE_NAME

It offers, at once, so one process serves a whole test module:
- `/from_ros` (std_msgs/msg/String, reliable): every message received on `/to_ros`, echoed
  back as "echo: <data>";
- `/ros_chatter` (std_msgs/msg/String, reliable): "hello <n>" at 10 Hz;
- `/sensor_be` (std_msgs/msg/String, best effort keep-last 5, rclpy's `qos_profile_sensor_data`):
  "sensor <n>" at 10 Hz;
- parameters `gain` (double 1.5), `label` (string "riverbridge"), `enabled` (bool true); a
  parameter set from outside is published as "<name>=<value>" on `/param_seen`
  (transient local), the value the node itself reads back with `get_parameter`;
- the action `/fibonacci` (test_msgs/action/Fibonacci): one feedback per step every 0.1 s,
  cancel honoured.
Prints "READY" once everything exists. Stops on SIGINT/SIGTERM.
"""

from __future__ import annotations

import signal
import sys
import threading
import time

import rclpy
from rcl_interfaces.msg import SetParametersResult
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from std_msgs.msg import String
from test_msgs.action import Fibonacci

STEP_S = 0.1


class TestNode(Node):
    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.echo = self.create_publisher(String, "/from_ros", 10)
        self.chatter = self.create_publisher(String, "/ros_chatter", 10)
        self.sensor = self.create_publisher(String, "/sensor_be", qos_profile_sensor_data)
        # transient local: a subscriber matched after the change still reads it
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.seen = self.create_publisher(String, "/param_seen", latched)
        self.create_subscription(String, "/to_ros", self._echo, 10)
        self.declare_parameter("gain", 1.5)
        self.declare_parameter("label", "riverbridge")
        self.declare_parameter("enabled", True)
        self.add_post_set_parameters_callback(self._params_set)
        self.add_on_set_parameters_callback(lambda params: SetParametersResult(successful=True))
        self.count = 0
        self.create_timer(0.1, self._tick)
        ActionServer(
            self,
            Fibonacci,
            "/fibonacci",
            execute_callback=self._fibonacci,
            goal_callback=lambda goal: GoalResponse.ACCEPT,
            cancel_callback=lambda goal: CancelResponse.ACCEPT,
        )

    def _echo(self, msg: String) -> None:
        self.echo.publish(String(data=f"echo: {msg.data}"))

    def _tick(self) -> None:
        self.count += 1
        self.chatter.publish(String(data=f"hello {self.count}"))
        self.sensor.publish(String(data=f"sensor {self.count}"))

    def _params_set(self, params: list) -> None:
        for param in params:
            value = self.get_parameter(param.name).value  # what the node itself now reads
            self.seen.publish(String(data=f"{param.name}={value!r}"))

    def _fibonacci(self, handle):  # type: ignore[no-untyped-def]
        sequence = [0, 1]
        for _ in range(1, handle.request.order):
            if handle.is_cancel_requested:
                handle.canceled()
                return Fibonacci.Result(sequence=sequence)
            sequence.append(sequence[-1] + sequence[-2])
            handle.publish_feedback(Fibonacci.Feedback(sequence=sequence))
            time.sleep(STEP_S)
        handle.succeed()
        return Fibonacci.Result(sequence=sequence)


def main(argv: list[str]) -> int:
    rclpy.init()
    node = TestNode(argv[0])
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    print("READY", flush=True)
    stop.wait()
    executor.shutdown(timeout_sec=2.0)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
