"""Facts about ROS 2 primitive field types, as rosbags spells them in its field definitions.

Tables, not branches: the registry classifies each field once with these, and the message
normaliser and the rosapi type definitions look values up here.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

import numpy as np

#: Integer primitives and their numpy dtypes. ``byte`` and ``char`` are unsigned octets in ROS 2.
INT_DTYPES: Mapping[str, np.dtype] = MappingProxyType(
    {
        "int8": np.dtype(np.int8),
        "uint8": np.dtype(np.uint8),
        "byte": np.dtype(np.uint8),
        "char": np.dtype(np.uint8),
        "int16": np.dtype(np.int16),
        "uint16": np.dtype(np.uint16),
        "int32": np.dtype(np.int32),
        "uint32": np.dtype(np.uint32),
        "int64": np.dtype(np.int64),
        "uint64": np.dtype(np.uint64),
    }
)

FLOAT_DTYPES: Mapping[str, np.dtype] = MappingProxyType(
    {"float32": np.dtype(np.float32), "float64": np.dtype(np.float64)}
)

NUMERIC_DTYPES: Mapping[str, np.dtype] = MappingProxyType({**INT_DTYPES, **FLOAT_DTYPES})

#: Inclusive value range of each integer primitive.
INT_RANGES: Mapping[str, tuple[int, int]] = MappingProxyType(
    {name: (int(np.iinfo(dt).min), int(np.iinfo(dt).max)) for name, dt in INT_DTYPES.items()}
)

#: Arrays of these travel as ``bytes`` (base64 in JSON, a byte string in CBOR).
OCTET_TYPES = frozenset({"uint8", "byte", "char"})

STRING_TYPES = frozenset({"string", "wstring"})

PRIMITIVE_TYPES = frozenset({"bool", *NUMERIC_DTYPES, *STRING_TYPES})

#: ROS 2 IDL names that rosapi reports in ``fieldtypes`` (``float64`` -> ``double``).
IDL_NAMES: Mapping[str, str] = MappingProxyType(
    {
        "bool": "boolean",
        "byte": "octet",
        "char": "uint8",
        "float32": "float",
        "float64": "double",
        **{name: name for name in INT_DTYPES if name not in ("byte", "char")},
        "string": "string",
        "wstring": "wstring",
    }
)

#: Largest finite float32 magnitude; finite values beyond it cannot be stored in a float32.
FLOAT32_MAX = float(np.finfo(np.float32).max)

#: Non-zero defaults declared in standard .msg files, which rosbags' store does not keep.
#: geometry_msgs/Quaternion declares ``float64 w 1`` so that a default rotation is the identity.
DECLARED_DEFAULTS: Mapping[tuple[str, str], object] = MappingProxyType(
    {("geometry_msgs/msg/Quaternion", "w"): 1.0}
)

TIME_TYPES = frozenset({"builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration"})
HEADER_TYPE = "std_msgs/msg/Header"


def scalar_default(base: str) -> object:
    """Default value of a primitive scalar: ``False``, ``0``, ``0.0`` or ``''``."""
    if base == "bool":
        return False
    if base in INT_DTYPES:
        return 0
    if base in FLOAT_DTYPES:
        return 0.0
    return ""
