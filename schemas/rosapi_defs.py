"""rosapi ``TypeDef`` records (``/rosapi/message_details`` and the service/action variants).

ROS 2 rosapi reports each type as ``pkg/Type``, primitive field types by their IDL names
(``double``, ``float``, ``boolean``, ``octet``), ``fieldarraylen`` -1 for a scalar, 0 for a
(bounded) sequence and N for a fixed array, and ``examples`` as the ``str`` of a default
(``'[]'`` for arrays, ``'{}'`` for messages). roslibjs and roslibpy resolve nested types by
matching ``fieldtypes`` entries against ``type``, so both use the same ``pkg/Type`` spelling.
"""

from __future__ import annotations

from schemas import primitives
from schemas.specs import FieldSpec, MessageSpec
from schemas.typenames import short_type_name

#: rosapi_msgs/msg/TypeDef as a dict: the type's name, then one list entry per field.
TypeDef = dict[str, str | list[str] | list[int]]


def _field_type(field: FieldSpec) -> str:
    if field.is_message:
        return short_type_name(field.base)
    return primitives.IDL_NAMES[field.base]


def _array_length(field: FieldSpec) -> int:
    if field.array is None:
        return -1
    return field.length if field.array == "fixed" else 0


def _example(field: FieldSpec) -> str:
    if field.array is not None:
        return "[]"
    if field.is_message:
        return "{}"
    return str(field.default)


def typedef(spec: MessageSpec) -> TypeDef:
    """The one TypeDef dict of ``spec`` (no nested types)."""
    return {
        "type": short_type_name(spec.name),
        "fieldnames": [f.name for f in spec.fields],
        "fieldtypes": [_field_type(f) for f in spec.fields],
        "fieldarraylen": [_array_length(f) for f in spec.fields],
        "examples": [_example(f) for f in spec.fields],
        "constnames": [name for name, _type, _value in spec.constants],
        "constvalues": [str(value) for _name, _type, value in spec.constants],
    }


def message_typedefs(spec: MessageSpec) -> list[TypeDef]:
    """TypeDefs of ``spec`` then of every nested type, depth first, each type once."""
    seen: set[str] = set()
    out: list[TypeDef] = []

    def visit(current: MessageSpec) -> None:
        if current.name in seen:
            return
        seen.add(current.name)
        out.append(typedef(current))
        for field in current.fields:
            if field.message is not None:
                visit(field.message)

    visit(spec)
    return out
