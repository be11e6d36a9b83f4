"""full_text (topics_and_raw_types) and typedefs (message_details) in the rosapi formats."""

SEPARATOR = "=" * 80


def _sections(text: str) -> dict[str, str]:
    chunks = text.split(SEPARATOR + "\n")
    out = {"": chunks[0]}
    for chunk in chunks[1:]:
        header, _, body = chunk.partition("\n")
        assert header.startswith("MSG: ")
        out[header.removeprefix("MSG: ")] = body
    return out


def test_imu_full_text(registry):
    text = registry.full_text("sensor_msgs/msg/Imu")
    sections = _sections(text)
    assert sections[""].splitlines()[0] == "std_msgs/Header header"
    assert "float64[9] orientation_covariance" in sections[""]
    assert set(sections) == {
        "",
        "std_msgs/Header",
        "builtin_interfaces/Time",
        "geometry_msgs/Quaternion",
        "geometry_msgs/Vector3",
    }
    # ROS 2 mode: the stamp is a builtin_interfaces/Time message, not the ROS 1 'time' type.
    assert sections["std_msgs/Header"].splitlines() == [
        "builtin_interfaces/Time stamp",
        "string frame_id",
    ]
    assert sections["builtin_interfaces/Time"].splitlines() == ["int32 sec", "uint32 nanosec"]
    assert "\ntime " not in text


def test_full_text_of_own_types_and_constants(registry):
    text = registry.full_text("riverbridge_msgs/RadarImage")
    assert "float32[] reflectance" in text
    assert "MSG: std_msgs/Header" in text
    log = registry.full_text("rcl_interfaces/msg/Log")
    assert "uint8 ERROR=40" in log.replace(" = ", "=")


def test_pose_typedefs(registry):
    typedefs = registry.typedefs("geometry_msgs/msg/Pose")
    assert [t["type"] for t in typedefs] == [
        "geometry_msgs/Pose",
        "geometry_msgs/Point",
        "geometry_msgs/Quaternion",
    ]
    assert typedefs[0] == {
        "type": "geometry_msgs/Pose",
        "fieldnames": ["position", "orientation"],
        "fieldtypes": ["geometry_msgs/Point", "geometry_msgs/Quaternion"],
        "fieldarraylen": [-1, -1],
        "examples": ["{}", "{}"],
        "constnames": [],
        "constvalues": [],
    }
    assert typedefs[1]["fieldtypes"] == ["double", "double", "double"]
    assert typedefs[1]["examples"] == ["0.0", "0.0", "0.0"]


def test_typedef_array_lengths_idl_names_and_constants(registry):
    typedefs = {t["type"]: t for t in registry.typedefs("sensor_msgs/NavSatFix")}
    fix = typedefs["sensor_msgs/NavSatFix"]
    cov = fix["fieldnames"].index("position_covariance")
    assert fix["fieldarraylen"][cov] == 9
    assert fix["fieldtypes"][cov] == "double"
    assert fix["fieldtypes"][fix["fieldnames"].index("position_covariance_type")] == "uint8"
    assert fix["constnames"][:1] == ["COVARIANCE_TYPE_UNKNOWN"]
    assert fix["constvalues"][:1] == ["0"]
    status = typedefs["sensor_msgs/NavSatStatus"]
    assert status["constvalues"][0] == "-2"
    assert "builtin_interfaces/Time" in typedefs  # nested via Header
    cloud = registry.typedefs("sensor_msgs/PointCloud2")[0]
    index = cloud["fieldnames"].index("data")
    assert (cloud["fieldtypes"][index], cloud["fieldarraylen"][index]) == ("uint8", 0)
    assert cloud["fieldtypes"][cloud["fieldnames"].index("is_dense")] == "boolean"
    assert cloud["examples"][cloud["fieldnames"].index("is_dense")] == "False"


def test_each_nested_type_once(registry):
    types = [t["type"] for t in registry.typedefs("visualization_msgs/msg/MarkerArray")]
    assert types[0] == "visualization_msgs/MarkerArray"
    assert len(types) == len(set(types))
    assert "std_msgs/ColorRGBA" in types
