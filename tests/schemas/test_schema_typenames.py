import pytest

from schemas.errors import InvalidTypeNameError, SchemaError
from schemas.typenames import is_valid_type_name, normalize_type_name, short_type_name

# rosbridge_library test_ros_loader (ROS 2): strings that must be rejected ...
BAD_NAMES = [
    "",
    "/",
    "//",
    "///",
    "////",
    "/////",
    "bad",
    "stillbad",
    "better/",
    "better//",
    "better///",
    "/better",
    "//better",
    "///better",
    r"this\isbad",
    "\\",
]
# ... and irregular spellings that must still resolve.
IRREGULAR_NAMES = [
    "std_msgs//String",
    "//std_msgs/String",
    "/std_msgs//String",
    "/std_msgs/String",
    "//std_msgs//String",
    "/std_msgs/String/",
    "//std_msgs//String//",
    "std_msgs/String/",
    "std_msgs//String//",
    "std_msgs/msg/String",
    "/std_msgs/msg//String/",
]


@pytest.mark.parametrize("name", BAD_NAMES)
def test_bad_names_are_rejected(name):
    with pytest.raises(InvalidTypeNameError):
        normalize_type_name(name)
    assert not is_valid_type_name(name)


@pytest.mark.parametrize("name", IRREGULAR_NAMES)
def test_irregular_names_normalize(name):
    assert normalize_type_name(name) == "std_msgs/msg/String"
    assert short_type_name(name) == "std_msgs/String"


def test_kind_fills_the_middle_part_only_when_missing():
    assert normalize_type_name("std_srvs/SetBool", "srv") == "std_srvs/srv/SetBool"
    assert normalize_type_name("example_interfaces/Fibonacci", "action") == (
        "example_interfaces/action/Fibonacci"
    )
    # Request/response messages keep their srv middle part when asked for as messages.
    assert normalize_type_name("std_srvs/srv/SetBool_Request") == "std_srvs/srv/SetBool_Request"


@pytest.mark.parametrize("name", ["a/foo/B", "not/better/still", "a/b/c/d", 5, None])
def test_other_shapes_are_invalid(name):
    with pytest.raises(InvalidTypeNameError):
        normalize_type_name(name)


def test_error_is_part_of_the_schema_tree():
    assert issubclass(InvalidTypeNameError, SchemaError)
