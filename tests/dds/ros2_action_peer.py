"""A plain Cyclone DDS participant serving what a ROS 2 node serves, written from the wire
conventions (rcl_action's names, rosidl's generated types, rmw_cyclonedds's request header),
with no riverbridge code: an action server, parameter services and a best-effort publisher.

usage: python3 ros2_action_peer.py DOMAIN serve NODE SECONDS
  - action `/peer_fibonacci` (example_interfaces/action/Fibonacci): `send_goal` accepts,
    one feedback per step every 0.1 s on `rt/peer_fibonacci/_action/feedback`, `get_result`
    answers when the goal ends, `cancel_goal` cancels (status CANCELED, 5);
  - `/NODE/get_parameters` and `/NODE/set_parameters` over one double parameter `gain` (1.5);
  - `rt/peer_sensor` (std_msgs/msg/String, best effort) at 10 Hz.
Prints "READY", then one JSON line with what it was asked when SECONDS have passed.

usage: python3 ros2_action_peer.py DOMAIN humble_node SECONDS
  a Humble node `/humble_talker`: its `ros_discovery_info` with Humble's 24-byte GIDs
  (rmw_dds_common/msg/Gid `char[24]`), owning a writer of `rt/humble_chatter` (String, 10 Hz).

usage: python3 ros2_action_peer.py DOMAIN params NODE TIMEOUT_S
  a parameter client of NODE (as `ros2 param` is): sets `gain` to 2.5, then lists NODE's
  parameters and gets `gain`, `preset` and `missing`; prints them as one JSON line.

usage: python3 ros2_action_peer.py DOMAIN client ACTION ORDER TIMEOUT_S
  an rcl_action client of ACTION (example_interfaces/action/Fibonacci): waits for the server,
  sends one goal (a UUID of its own), collects its feedback, asks `get_result`, reads the
  status topic; prints them as one JSON line.
"""

# No `from __future__ import annotations`: cyclonedds reads the field annotations as objects.
import json
import sys
import time
from dataclasses import dataclass, field

import cyclonedds.idl.types as t
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from ros2_wire import ROS2_DEFAULT_QOS, ServiceClients, Time, service_server

ACTION = "/peer_fibonacci"
STEP_S = 0.1
SUCCEEDED, CANCELED = 4, 5


@dataclass
class UUID(IdlStruct, typename="unique_identifier_msgs::msg::dds_::UUID_"):
    uuid: t.array[t.uint8, 16]


@dataclass
class GoalInfo(IdlStruct, typename="action_msgs::msg::dds_::GoalInfo_"):
    goal_id: UUID
    stamp: Time


@dataclass
class Goal(IdlStruct, typename="example_interfaces::action::dds_::Fibonacci_Goal_"):
    order: t.int32


@dataclass
class Result(IdlStruct, typename="example_interfaces::action::dds_::Fibonacci_Result_"):
    sequence: t.sequence[t.int32]


@dataclass
class Feedback(IdlStruct, typename="example_interfaces::action::dds_::Fibonacci_Feedback_"):
    sequence: t.sequence[t.int32]


# Service parts lead with rmw_cyclonedds_cpp's cdds_request_header_t (guid, seq).
@dataclass
class SendGoalRequest(
    IdlStruct, typename="example_interfaces::action::dds_::Fibonacci_SendGoal_Request_"
):
    guid: t.uint64
    seq: t.int64
    goal_id: UUID
    goal: Goal


@dataclass
class SendGoalResponse(
    IdlStruct, typename="example_interfaces::action::dds_::Fibonacci_SendGoal_Response_"
):
    guid: t.uint64
    seq: t.int64
    accepted: bool
    stamp: Time


@dataclass
class GetResultRequest(
    IdlStruct, typename="example_interfaces::action::dds_::Fibonacci_GetResult_Request_"
):
    guid: t.uint64
    seq: t.int64
    goal_id: UUID


@dataclass
class GetResultResponse(
    IdlStruct, typename="example_interfaces::action::dds_::Fibonacci_GetResult_Response_"
):
    guid: t.uint64
    seq: t.int64
    status: t.int8
    result: Result


@dataclass
class FeedbackMessage(
    IdlStruct, typename="example_interfaces::action::dds_::Fibonacci_FeedbackMessage_"
):
    goal_id: UUID
    feedback: Feedback


@dataclass
class CancelRequest(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Request_"):
    guid: t.uint64
    seq: t.int64
    goal_info: GoalInfo


@dataclass
class CancelResponse(IdlStruct, typename="action_msgs::srv::dds_::CancelGoal_Response_"):
    guid: t.uint64
    seq: t.int64
    return_code: t.int8
    goals_canceling: t.sequence[GoalInfo]


@dataclass
class ParameterValue(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterValue_"):
    type: t.uint8
    bool_value: bool
    integer_value: t.int64
    double_value: t.float64
    string_value: str
    byte_array_value: t.sequence[t.byte]
    bool_array_value: t.sequence[bool]
    integer_array_value: t.sequence[t.int64]
    double_array_value: t.sequence[t.float64]
    string_array_value: t.sequence[str]


@dataclass
class Parameter(IdlStruct, typename="rcl_interfaces::msg::dds_::Parameter_"):
    name: str
    value: ParameterValue


@dataclass
class SetParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::SetParametersResult_"):
    successful: bool
    reason: str


@dataclass
class GetParametersRequest(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Request_"):
    guid: t.uint64
    seq: t.int64
    names: t.sequence[str]


@dataclass
class GetParametersResponse(
    IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Response_"
):
    guid: t.uint64
    seq: t.int64
    values: t.sequence[ParameterValue]


@dataclass
class SetParametersRequest(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Request_"):
    guid: t.uint64
    seq: t.int64
    parameters: t.sequence[Parameter]


@dataclass
class SetParametersResponse(
    IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Response_"
):
    guid: t.uint64
    seq: t.int64
    results: t.sequence[SetParametersResult]


@dataclass
class GoalStatus(IdlStruct, typename="action_msgs::msg::dds_::GoalStatus_"):
    goal_info: GoalInfo
    status: t.int8


@dataclass
class GoalStatusArray(IdlStruct, typename="action_msgs::msg::dds_::GoalStatusArray_"):
    status_list: t.sequence[GoalStatus]


@dataclass
class ListParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::ListParametersResult_"):
    names: t.sequence[str]
    prefixes: t.sequence[str]


@dataclass
class ListParametersRequest(
    IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Request_"
):
    guid: t.uint64
    seq: t.int64
    prefixes: t.sequence[str]
    depth: t.uint64


@dataclass
class ListParametersResponse(
    IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Response_"
):
    guid: t.uint64
    seq: t.int64
    result: ListParametersResult


@dataclass
class FloatingPointRange(IdlStruct, typename="rcl_interfaces::msg::dds_::FloatingPointRange_"):
    from_value: float
    to_value: float
    step: float


@dataclass
class IntegerRange(IdlStruct, typename="rcl_interfaces::msg::dds_::IntegerRange_"):
    from_value: t.int64
    to_value: t.int64
    step: t.uint64


@dataclass
class ParameterDescriptor(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterDescriptor_"):
    name: str
    type: t.uint8
    description: str
    additional_constraints: str
    read_only: bool
    dynamic_typing: bool
    floating_point_range: t.sequence[FloatingPointRange, 1]
    integer_range: t.sequence[IntegerRange, 1]


@dataclass
class DescribeParametersRequest(
    IdlStruct, typename="rcl_interfaces::srv::dds_::DescribeParameters_Request_"
):
    guid: t.uint64
    seq: t.int64
    names: t.sequence[str]


@dataclass
class DescribeParametersResponse(
    IdlStruct, typename="rcl_interfaces::srv::dds_::DescribeParameters_Response_"
):
    guid: t.uint64
    seq: t.int64
    descriptors: t.sequence[ParameterDescriptor]


@dataclass
class GetParameterTypesRequest(
    IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameterTypes_Request_"
):
    guid: t.uint64
    seq: t.int64
    names: t.sequence[str]


@dataclass
class GetParameterTypesResponse(
    IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameterTypes_Response_"
):
    guid: t.uint64
    seq: t.int64
    types: t.sequence[t.uint8]


@dataclass
class HumbleGid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: t.array[t.uint8, 24]


@dataclass
class HumbleNodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    node_namespace: t.bounded_str[256]
    node_name: t.bounded_str[256]
    reader_gid_seq: t.sequence[HumbleGid]
    writer_gid_seq: t.sequence[HumbleGid]


@dataclass
class HumbleParticipantEntitiesInfo(
    IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"
):
    gid: HumbleGid
    node_entities_info_seq: t.sequence[HumbleNodeEntitiesInfo]


@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


RELIABLE = ROS2_DEFAULT_QOS
BEST_EFFORT = Qos(
    Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(5)
)


def double(value: float) -> ParameterValue:
    return ParameterValue(3, False, 0, value, "", [], [], [], [], [])


NOT_SET = ParameterValue(0, False, 0, 0.0, "", [], [], [], [], [])


@dataclass
class RunningGoal:
    order: int
    sequence: list = field(default_factory=lambda: [0, 1])
    next_step_s: float = 0.0
    status: int = 0


class Peer:
    def __init__(self, participant: DomainParticipant, node: str) -> None:
        self.participant = participant
        self.servers = {}
        for name, request, response in (
            (f"{ACTION}/_action/send_goal", SendGoalRequest, SendGoalResponse),
            (f"{ACTION}/_action/get_result", GetResultRequest, GetResultResponse),
            (f"{ACTION}/_action/cancel_goal", CancelRequest, CancelResponse),
            (f"/{node}/get_parameters", GetParametersRequest, GetParametersResponse),
            (f"/{node}/set_parameters", SetParametersRequest, SetParametersResponse),
        ):
            user_data = f"serviceid=peer.{len(self.servers)};".encode()
            self.servers[name.rsplit("/", 1)[1]] = service_server(
                participant, name, request, response, user_data
            )
        self.feedback = DataWriter(
            participant,
            Topic(participant, f"rt{ACTION}/_action/feedback", FeedbackMessage),
            RELIABLE,
        )
        self.sensor = DataWriter(
            participant, Topic(participant, "rt/peer_sensor", String), BEST_EFFORT
        )
        self.goals: dict[bytes, RunningGoal] = {}
        self.waiting_results: list[GetResultRequest] = []
        self.gain = 1.5
        self.seen: dict = {"goals": [], "canceled": [], "set": []}

    def step(self, now_s: float) -> None:
        self._serve("send_goal", self._send_goal)
        self._serve("cancel_goal", self._cancel)
        self._serve("get_parameters", self._get_parameters)
        self._serve("set_parameters", self._set_parameters)
        reader, _ = self.servers["get_result"]
        self.waiting_results.extend(reader.take(N=16))
        for goal_id, goal in self.goals.items():
            if goal.status == 0 and now_s >= goal.next_step_s:
                self._advance(goal_id, goal, now_s)
        self._answer_results()

    def _serve(self, name: str, answer) -> None:
        reader, writer = self.servers[name]
        for request in reader.take(N=16):
            writer.write(answer(request))

    def _send_goal(self, request: SendGoalRequest) -> SendGoalResponse:
        self.goals[bytes(request.goal_id.uuid)] = RunningGoal(request.goal.order)
        self.seen["goals"].append(request.goal.order)
        return SendGoalResponse(request.guid, request.seq, True, Time(0, 0))

    def _advance(self, goal_id: bytes, goal: RunningGoal, now_s: float) -> None:
        if len(goal.sequence) > goal.order:
            goal.status = SUCCEEDED
            return
        goal.sequence.append(goal.sequence[-1] + goal.sequence[-2])
        self.feedback.write(FeedbackMessage(UUID(list(goal_id)), Feedback(list(goal.sequence))))
        goal.next_step_s = now_s + STEP_S

    def _cancel(self, request: CancelRequest) -> CancelResponse:
        goal_id = bytes(request.goal_info.goal_id.uuid)
        goal = self.goals.get(goal_id)
        if goal is None or goal.status != 0:
            return CancelResponse(request.guid, request.seq, 2, [])
        goal.status = CANCELED
        self.seen["canceled"].append(goal.order)
        return CancelResponse(request.guid, request.seq, 0, [request.goal_info])

    def _answer_results(self) -> None:
        _, writer = self.servers["get_result"]
        still = []
        for request in self.waiting_results:
            goal = self.goals.get(bytes(request.goal_id.uuid))
            if goal is not None and goal.status != 0:
                result = Result(list(goal.sequence))
                writer.write(GetResultResponse(request.guid, request.seq, goal.status, result))
            else:
                still.append(request)
        self.waiting_results = still

    def _get_parameters(self, request: GetParametersRequest) -> GetParametersResponse:
        values = [double(self.gain) if name == "gain" else NOT_SET for name in request.names]
        return GetParametersResponse(request.guid, request.seq, values)

    def _set_parameters(self, request: SetParametersRequest) -> SetParametersResponse:
        results = []
        for parameter in request.parameters:
            ok = parameter.name == "gain" and parameter.value.type == 3
            if ok:
                self.gain = parameter.value.double_value
                self.seen["set"].append(self.gain)
            results.append(SetParametersResult(ok, "" if ok else "only gain, a double"))
        return SetParametersResponse(request.guid, request.seq, results)


class ActionClient(ServiceClients):
    """rcl_action's client: `send_goal` and `get_result`, with the feedback and status
    readers."""

    def __init__(self, participant: DomainParticipant, action: str) -> None:
        super().__init__(
            participant,
            (
                (f"{action}/_action/send_goal", SendGoalRequest, SendGoalResponse),
                (f"{action}/_action/get_result", GetResultRequest, GetResultResponse),
            ),
        )
        self.feedback = DataReader(
            participant,
            Topic(participant, f"rt{action}/_action/feedback", FeedbackMessage),
            RELIABLE,
        )
        status_qos = Qos(
            Policy.Reliability.Reliable(1_000_000_000),
            Policy.Durability.TransientLocal,
            Policy.History.KeepLast(1),
        )
        self.status = DataReader(
            participant,
            Topic(participant, f"rt{action}/_action/status", GoalStatusArray),
            status_qos,
        )


def run_params(participant: DomainParticipant, node: str, timeout_s: float) -> dict:
    client = ServiceClients(
        participant,
        (
            (f"/{node}/set_parameters", SetParametersRequest, SetParametersResponse),
            (f"/{node}/list_parameters", ListParametersRequest, ListParametersResponse),
            (f"/{node}/get_parameters", GetParametersRequest, GetParametersResponse),
            (
                f"/{node}/describe_parameters",
                DescribeParametersRequest,
                DescribeParametersResponse,
            ),
            (f"/{node}/get_parameter_types", GetParameterTypesRequest, GetParameterTypesResponse),
        ),
    )
    deadline_s = time.monotonic() + timeout_s
    if not client.wait_matched(deadline_s):
        return {"ok": False, "reason": f"/{node}'s parameter services were never matched"}
    gain = Parameter("gain", double(2.5))
    set_reply = client.call(
        "set_parameters", SetParametersRequest(client.guid, 1, [gain]), deadline_s
    )
    listed = client.call(
        "list_parameters", ListParametersRequest(client.guid, 2, [], 0), deadline_s
    )
    names = ["gain", "preset", "missing"]
    got = client.call("get_parameters", GetParametersRequest(client.guid, 3, names), deadline_s)
    described = client.call(
        "describe_parameters", DescribeParametersRequest(client.guid, 4, names), deadline_s
    )
    types = client.call(
        "get_parameter_types", GetParameterTypesRequest(client.guid, 5, names), deadline_s
    )
    return {
        "descriptors": [[d.name, d.type] for d in described.descriptors],
        "types": list(types.types),
        "ok": True,
        "set": [[r.successful, r.reason] for r in set_reply.results],
        "names": sorted(listed.result.names),
        "values": [[v.type, v.double_value, v.integer_value] for v in got.values],
    }


def run_client(participant: DomainParticipant, action: str, order: int, timeout_s: float) -> dict:
    client = ActionClient(participant, action)
    deadline_s = time.monotonic() + timeout_s
    if not client.wait_matched(deadline_s):
        return {"ok": False, "reason": "the action server was never matched"}
    goal_id = UUID(list(range(1, 17)))
    accepted = client.call(
        "send_goal", SendGoalRequest(client.guid, 1, goal_id, Goal(order)), deadline_s
    )
    result = client.call("get_result", GetResultRequest(client.guid, 2, goal_id), deadline_s)
    feedback = [list(m.feedback.sequence) for m in client.feedback.take(N=100)]
    statuses = [
        [(list(s.goal_info.goal_id.uuid), s.status) for s in array.status_list]
        for array in client.status.read(N=10)
    ]
    return {
        "ok": True,
        "accepted": accepted.accepted,
        "status": result.status,
        "sequence": list(result.result.sequence),
        "feedback": feedback,
        "statuses": statuses,
    }


def humble_gid(guid: bytes) -> HumbleGid:
    return HumbleGid(list(guid) + [0] * 8)


def run_humble_node(participant: DomainParticipant, seconds: float) -> dict:
    chatter = DataWriter(participant, Topic(participant, "rt/humble_chatter", String), RELIABLE)
    discovery_qos = Qos(
        Policy.Reliability.Reliable(1_000_000_000),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(1),
    )
    info = DataWriter(
        participant,
        Topic(participant, "ros_discovery_info", HumbleParticipantEntitiesInfo),
        discovery_qos,
    )
    node = HumbleNodeEntitiesInfo("/", "humble_talker", [], [humble_gid(chatter.guid.bytes)])
    info.write(HumbleParticipantEntitiesInfo(humble_gid(participant.guid.bytes), [node]))
    print("READY", flush=True)
    end_s, count = time.monotonic() + seconds, 0
    while time.monotonic() < end_s:
        count += 1
        chatter.write(String(f"humble {count}"))
        time.sleep(0.1)
    return {"ok": True, "sent": count}


def main(argv: list[str]) -> int:
    domain, mode, *args = argv
    participant = DomainParticipant(int(domain))
    if mode == "params":
        result = run_params(participant, args[0], float(args[1]))
        print(json.dumps(result), flush=True)
        return 0 if result["ok"] else 1
    if mode == "humble_node":
        print(json.dumps(run_humble_node(participant, float(args[0]))), flush=True)
        return 0
    if mode == "client":
        result = run_client(participant, args[0], int(args[1]), float(args[2]))
        print(json.dumps(result), flush=True)
        return 0 if result["ok"] else 1
    node, seconds = args
    peer = Peer(participant, node)
    print("READY", flush=True)
    end_s = time.monotonic() + float(seconds)
    next_sensor_s, count = 0.0, 0
    while (now_s := time.monotonic()) < end_s:
        peer.step(now_s)
        if now_s >= next_sensor_s:
            count += 1
            peer.sensor.write(String(f"peer sensor {count}"))
            next_sensor_s = now_s + 0.1
        time.sleep(0.01)
    print(json.dumps({"ok": True, **peer.seen}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
