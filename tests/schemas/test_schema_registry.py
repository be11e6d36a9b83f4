import numpy as np
import pytest

from schemas.errors import InvalidTypeNameError, SchemaError, UnknownTypeError
from schemas.registry import TypeRegistry

SHIPPED_SERVICES = [
    "std_srvs/srv/Empty",
    "std_srvs/srv/Trigger",
    "std_srvs/srv/SetBool",
    "example_interfaces/srv/AddTwoInts",
    "rosapi_msgs/srv/TopicsAndRawTypes",
    "rosapi_msgs/srv/MessageDetails",
    "rosapi_msgs/srv/NodeDetails",
    "rosapi_msgs/srv/GetParam",
    "rosapi_msgs/srv/SetParam",
    "rosapi_msgs/srv/HasParam",
    "rosapi_msgs/srv/DeleteParam",
    "rosapi_msgs/srv/GetParamNames",
    "rosapi_msgs/srv/GetTime",
    "rosapi_msgs/srv/GetROSVersion",
    "rosapi_msgs/srv/ServiceType",
    "rosapi_msgs/srv/TopicType",
    "rosapi_msgs/srv/Topics",
    "rosapi_msgs/srv/TopicsForType",
    "rosapi_msgs/srv/Services",
    "rosapi_msgs/srv/ServicesForType",
    "rosapi_msgs/srv/Nodes",
    "rosapi_msgs/srv/Publishers",
    "rosapi_msgs/srv/Subscribers",
    "rosapi_msgs/srv/ServiceProviders",
    "rosapi_msgs/srv/ServiceNode",
    "rosapi_msgs/srv/ServiceRequestDetails",
    "rosapi_msgs/srv/ServiceResponseDetails",
    "rosapi_msgs/srv/ActionServers",
    "rosapi_msgs/srv/GetActionServers",
    "rosapi_msgs/srv/ActionType",
    "rosapi_msgs/srv/Interfaces",
    "rcl_interfaces/srv/GetParameters",
    "rcl_interfaces/srv/SetParameters",
    "rcl_interfaces/srv/ListParameters",
    "rcl_interfaces/srv/DescribeParameters",
]
RIVERBRIDGE_MSGS = [
    "Box",
    "BoxArray",
    "GroundTruthArray",
    "GroundTruthObject",
    "ImageLine",
    "ImageLineArray",
    "RadarDetection",
    "RadarDetectionArray",
    "RadarImage",
    "RadarTarget",
]


def test_knows_the_standard_messages(registry):
    standard = [name for name in registry.message_names() if "/msg/" in name]
    assert len(standard) >= 150
    for name in (
        "sensor_msgs/msg/PointCloud2",
        "rcl_interfaces/msg/Log",
        "tf2_msgs/msg/TFMessage",
        "visualization_msgs/msg/MarkerArray",
        "nav_msgs/msg/OccupancyGrid",
    ):
        assert registry.has_message(name)


@pytest.mark.parametrize("name", SHIPPED_SERVICES)
def test_knows_the_shipped_services(registry, name):
    spec = registry.service(name)
    assert spec.request.name == name + "_Request"
    assert spec.response.name == name + "_Response"
    assert registry.has_message(spec.request.name)
    assert name in registry.service_names()


@pytest.mark.parametrize("name", RIVERBRIDGE_MSGS)
def test_knows_riverbridge_msgs(registry, name):
    assert registry.message(f"riverbridge_msgs/{name}").name == f"riverbridge_msgs/msg/{name}"


def test_service_fields_match_ros(registry):
    set_bool = registry.service("std_srvs/SetBool")
    assert [f.name for f in set_bool.request.fields] == ["data"]
    assert [f.name for f in set_bool.response.fields] == ["success", "message"]
    get_param = registry.service("rosapi_msgs/GetParam").request
    assert [f.name for f in get_param.fields] == ["name", "default_value"]
    raw_types = registry.service("rosapi_msgs/srv/TopicsAndRawTypes").response
    assert [f.name for f in raw_types.fields] == ["topics", "types", "typedefs_full_text"]
    get_time = registry.service("rosapi_msgs/GetTime").response
    assert get_time.fields[0].base == "builtin_interfaces/msg/Time"


def test_action_parts(registry):
    fib = registry.action("example_interfaces/Fibonacci")
    assert fib.name == "example_interfaces/action/Fibonacci"
    assert fib.goal.name == "example_interfaces/action/Fibonacci_Goal"
    assert fib.goal.fields[0].name == "order"
    assert fib.result.fields[0].dtype == np.int32
    assert fib.feedback.fields[0].array == "sequence"
    assert registry.action_names() == [
        "example_interfaces/action/Fibonacci",
        "test_msgs/action/Fibonacci",
    ]


def test_actions_have_rcl_actions_wire_types(registry):
    """rosidl's `<T>_SendGoal`/`_GetResult` services and `_FeedbackMessage`, as on DDS."""
    send_goal = registry.service("test_msgs/action/Fibonacci_SendGoal")
    assert [(f.name, f.base) for f in send_goal.request.fields] == [
        ("goal_id", "unique_identifier_msgs/msg/UUID"),
        ("goal", "test_msgs/action/Fibonacci_Goal"),
    ]
    assert [f.name for f in send_goal.response.fields] == ["accepted", "stamp"]
    result = registry.service("test_msgs/action/Fibonacci_GetResult").response
    assert [(f.name, f.base) for f in result.fields] == [
        ("status", "int8"),
        ("result", "test_msgs/action/Fibonacci_Result"),
    ]
    feedback = registry.message("test_msgs/action/Fibonacci_FeedbackMessage")
    assert [f.name for f in feedback.fields] == ["goal_id", "feedback"]
    cancel = registry.service("action_msgs/srv/CancelGoal")
    assert [f.name for f in cancel.response.fields] == ["return_code", "goals_canceling"]


def test_both_spellings_give_the_same_spec(registry):
    assert registry.message("std_msgs/String") is registry.message("std_msgs/msg/String")
    assert registry.message("std_srvs/SetBool_Request").name == "std_srvs/srv/SetBool_Request"
    assert registry.message("/std_srvs//SetBool_Request").name == "std_srvs/srv/SetBool_Request"
    assert registry.service("std_srvs/msg/SetBool").name == "std_srvs/srv/SetBool"


def test_field_classification(registry):
    imu = registry.message("sensor_msgs/msg/Imu").by_name
    assert imu["orientation_covariance"].array == "fixed"
    assert imu["orientation_covariance"].length == 9
    assert imu["orientation_covariance"].category == "numeric_fixed"
    assert imu["header"].is_message and imu["header"].message.name == "std_msgs/msg/Header"
    cloud = registry.message("sensor_msgs/msg/PointCloud2").by_name
    assert cloud["data"].category == "bytes"
    assert cloud["fields"].category == "message_array"
    grid = registry.message("nav_msgs/msg/OccupancyGrid").by_name
    assert grid["data"].category == "numeric_sequence" and grid["data"].dtype == np.int8
    descriptor = registry.message("rcl_interfaces/msg/ParameterDescriptor").by_name
    assert descriptor["integer_range"].array == "bounded"
    assert descriptor["integer_range"].length == 1


def test_errors(registry):
    with pytest.raises(InvalidTypeNameError):
        registry.message("bad")
    with pytest.raises(UnknownTypeError, match="std_msgs/Spool"):
        registry.message("std_msgs/Spool")
    with pytest.raises(UnknownTypeError):
        registry.service("std_srvs/Nope")
    with pytest.raises(UnknownTypeError):
        registry.action("std_msgs/String")
    assert not registry.has_message("bad")
    assert not registry.has_message(None)
    assert not registry.has_service("std_msgs/String")
    assert not registry.has_action("")


def test_user_directory(tmp_path):
    pkg = tmp_path / "my_pkg"
    (pkg / "msg").mkdir(parents=True)
    (pkg / "srv").mkdir()
    (pkg / "action").mkdir()
    (pkg / "msg" / "Ping.msg").write_text("uint32 seq\nstring<=8 tag\nfloat32[3] v\n")
    (pkg / "srv" / "Echo.srv").write_text("Ping ping\n---\nPing pong\n")
    (pkg / "action" / "Count.action").write_text("int32 to\n---\nbool done\n---\nint32 at\n")
    registry = TypeRegistry.with_defaults([tmp_path])
    assert registry.message("my_pkg/Ping").by_name["tag"].string_bound == 8
    echo = registry.service("my_pkg/Echo")
    assert echo.request.fields[0].message.name == "my_pkg/msg/Ping"
    assert registry.action("my_pkg/Count").feedback.fields[0].name == "at"


def test_bad_user_directories(tmp_path):
    registry = TypeRegistry()
    with pytest.raises(SchemaError, match="does not exist"):
        registry.add_directory(tmp_path / "missing")
    (tmp_path / "p" / "srv").mkdir(parents=True)
    (tmp_path / "p" / "srv" / "Half.srv").write_text("int32 a\n")
    with pytest.raises(SchemaError, match="section"):
        registry.add_directory(tmp_path)
    (tmp_path / "p" / "srv" / "Half.srv").unlink()
    (tmp_path / "p" / "msg").mkdir()
    (tmp_path / "p" / "msg" / "Dangling.msg").write_text("Missing thing\n")
    with pytest.raises(UnknownTypeError, match="p/msg/Missing"):
        registry.add_directory(tmp_path)


def test_conflicting_redefinition_is_refused(tmp_path):
    (tmp_path / "std_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "std_msgs" / "msg" / "String.msg").write_text("int32 data\n")
    with pytest.raises(SchemaError, match="different definition"):
        TypeRegistry().add_directory(tmp_path)


def test_registries_do_not_share_state(tmp_path):
    (tmp_path / "solo" / "msg").mkdir(parents=True)
    (tmp_path / "solo" / "msg" / "Only.msg").write_text("bool flag\n")
    first = TypeRegistry.with_defaults([tmp_path])
    second = TypeRegistry.with_defaults()
    assert first.has_message("solo/Only")
    assert not second.has_message("solo/Only")


def test_irregular_spellings_are_not_cached():
    registry = TypeRegistry()
    for slashes in range(1, 50):
        registry.message("std_msgs" + "/" * slashes + "String")
    assert len(registry._specs) <= 2  # canonical and short spelling only


def test_messages_without_fields_have_no_fields(registry):
    """rosbags' CDR placeholder member must not leak to clients (rosbridge sends ``{}``)."""
    from schemas.codec_cdr import from_cdr, to_cdr
    from schemas.message import normalize

    assert registry.message("std_msgs/msg/Empty").fields == ()
    assert registry.service("std_srvs/srv/Trigger").request.fields == ()
    assert registry.typedefs("std_msgs/Empty")[0]["fieldnames"] == []
    empty = normalize(registry.message("std_msgs/msg/Empty"), {}, now_ns=0)
    assert empty == {}
    cdr = to_cdr(registry, "std_msgs/msg/Empty", empty)
    assert from_cdr(registry, "std_msgs/msg/Empty", cdr) == {}


def test_action_parts_without_definition_text_are_a_schema_error(registry):
    """rosbags writes definition text for `/msg/` types only: an action's feedback message
    (a DDS topic Foxglove would show) is an UnknownTypeError, not an AssertionError that
    took down a Foxglove client's handshake."""
    with pytest.raises(UnknownTypeError, match="no definition text"):
        registry.full_text("test_msgs/action/Fibonacci_FeedbackMessage")
    assert "MSG: std_msgs/Header" in registry.full_text("sensor_msgs/msg/Imu")


def _bulk_in(value: object) -> list[object]:
    """Every ndarray and bytes value anywhere in a canonical message."""
    if isinstance(value, np.ndarray | bytes):
        return [value]
    if isinstance(value, dict):
        return [found for item in value.values() for found in _bulk_in(item)]
    if isinstance(value, list):
        return [found for item in value for found in _bulk_in(item)]
    return []


def test_bulk_free_types_hold_no_bytes_or_arrays_and_the_others_do() -> None:
    """`bulk_free` lets the bridge skip walking small messages for bulk data: a type it
    calls bulk-free must never hold any, at any depth (a default message has every fixed
    nested message and an empty value for every sequence), and every type whose default
    holds a float32 array must say it has one (JSON widens those)."""
    from schemas.message import default_message

    registry = TypeRegistry()
    names = registry.message_names()
    assert len(names) > 100
    bulk_free = 0
    for name in names:
        spec = registry.message(name)
        found = _bulk_in(default_message(spec))
        if spec.bulk_free:
            bulk_free += 1
            assert found == [], name
        else:
            assert found or any(f.category == "message_array" for f in spec.fields), name
        if any(isinstance(v, np.ndarray) and v.dtype == np.float32 for v in found):
            assert spec.has_float32_sequence, name
    assert 0 < bulk_free < len(names)


@pytest.mark.parametrize(
    ("name", "bulk_free", "float32"),
    [
        ("std_msgs/msg/String", True, False),
        ("sensor_msgs/msg/Imu", True, False),  # nested messages, fixed float64[9] lists
        ("geometry_msgs/msg/TwistStamped", True, False),
        ("sensor_msgs/msg/PointCloud2", False, False),  # uint8[] data: bytes
        ("sensor_msgs/msg/LaserScan", False, True),
        ("sensor_msgs/msg/PointCloud", False, True),  # float32[] inside ChannelFloat32[]
        ("std_msgs/msg/Float32MultiArray", False, True),
    ],
)
def test_bulk_and_float32_flags_of_known_types(name: str, bulk_free: bool, float32: bool) -> None:
    spec = TypeRegistry().message(name)
    assert (spec.bulk_free, spec.has_float32_sequence) == (bulk_free, float32)
