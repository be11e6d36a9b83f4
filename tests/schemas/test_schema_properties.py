"""Property tests: random messages of random registered types survive every codec."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from schemas import codec_cbor, codec_json, ops, primitives, specs
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.errors import MessageValidationError
from schemas.message import normalize
from schemas.registry import TypeRegistry
from schemas.specs import FieldSpec, MessageSpec

REGISTRY = TypeRegistry.with_defaults()
TYPE_NAMES = REGISTRY.message_names()
MAX_ITEMS = 3
# CDR strings are NUL-terminated, so generated text avoids NUL.
TEXT = st.text(alphabet=st.characters(exclude_categories=["Cs"], exclude_characters="\x00"))


def _scalar(field: FieldSpec, finite: bool) -> st.SearchStrategy:
    base = field.base
    if base == "bool":
        return st.booleans()
    if base in primitives.INT_RANGES:
        low, high = primitives.INT_RANGES[base]
        return st.integers(low, high)
    if base in primitives.FLOAT_DTYPES:
        if base == "float32":
            return st.floats(width=32, allow_nan=not finite, allow_infinity=not finite)
        return st.floats(allow_nan=not finite, allow_infinity=not finite)
    bound = field.string_bound or None
    return TEXT if bound is None else st.text(alphabet="abc xyz", max_size=bound)


def _sizes(field: FieldSpec) -> tuple[int, int]:
    if field.array == "fixed":
        return field.length, field.length
    if field.array == "bounded":
        return 0, min(field.length, MAX_ITEMS)
    return 0, MAX_ITEMS


def _field(field: FieldSpec, finite: bool) -> st.SearchStrategy:
    low, high = _sizes(field)
    if field.message is not None:
        sub = message_strategy(field.message, finite)
        return sub if field.array is None else st.lists(sub, min_size=low, max_size=high)
    longest = high * 5 if field.array == "sequence" else high
    category = field.category
    if category == specs.BYTES:
        return st.binary(min_size=low, max_size=longest)
    if category == specs.NUMERIC_SEQUENCE:
        assert field.dtype is not None
        elements = _scalar(field, finite) if field.dtype.kind == "f" else None
        return hnp.arrays(field.dtype, st.integers(low, longest), elements=elements)
    if field.array is not None:  # fixed numeric, bool and string arrays: plain lists
        return st.lists(_scalar(field, finite), min_size=low, max_size=high)
    return _scalar(field, finite)


def message_strategy(spec: MessageSpec, finite: bool) -> st.SearchStrategy:
    return st.fixed_dictionaries({f.name: _field(f, finite) for f in spec.fields})


def typed_messages(finite: bool) -> st.SearchStrategy:
    specs_strategy = st.sampled_from(TYPE_NAMES).map(REGISTRY.message)
    return specs_strategy.flatmap(
        lambda spec: st.tuples(st.just(spec), message_strategy(spec, finite))
    )


def same(a, b) -> bool:
    """Equality that treats NaN as equal to NaN and checks ndarray dtypes."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, np.ndarray):
        return (
            isinstance(b, np.ndarray)
            and a.dtype == b.dtype
            and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
        )
    if isinstance(a, float) and math.isnan(a):
        return isinstance(b, float) and math.isnan(b)
    return type(a) is type(b) and a == b


PROPERTY_SETTINGS = settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)


@PROPERTY_SETTINGS
@given(typed_messages(finite=True))
def test_json_round_trip(case):
    spec, raw = case
    msg = normalize(spec, raw, now_ns=1)
    assert same(normalize(spec, codec_json.loads(codec_json.dumps(msg)), now_ns=2), msg)


@PROPERTY_SETTINGS
@given(typed_messages(finite=False))
def test_cbor_round_trip(case):
    spec, raw = case
    msg = normalize(spec, raw, now_ns=1)
    assert same(normalize(spec, codec_cbor.loads(codec_cbor.dumps(msg)), now_ns=2), msg)


@PROPERTY_SETTINGS
@given(typed_messages(finite=False))
def test_cdr_round_trip(case):
    spec, raw = case
    msg = normalize(spec, raw, now_ns=1)
    assert same(from_cdr(REGISTRY, spec.name, to_cdr(REGISTRY, spec.name, msg)), msg)


@PROPERTY_SETTINGS
@given(typed_messages(finite=False))
def test_normalize_is_idempotent(case):
    spec, raw = case
    msg = normalize(spec, raw, now_ns=1)
    assert same(normalize(spec, msg, now_ns=2), msg)


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4)
    ),
    max_leaves=12,
)


def _garbage_for(spec: MessageSpec) -> st.SearchStrategy:
    """Objects with the spec's own field names (so the walk goes deep) holding any JSON."""
    names = st.sampled_from([f.name for f in spec.fields] or ["x"])
    return st.dictionaries(names, JSON_VALUES, max_size=4) | JSON_VALUES


@PROPERTY_SETTINGS
@given(
    st.sampled_from(TYPE_NAMES)
    .map(REGISTRY.message)
    .flatmap(lambda spec: st.tuples(st.just(spec), _garbage_for(spec)))
)
def test_any_json_either_normalizes_or_raises_validation_error(case):
    spec, raw = case
    try:
        normalize(spec, raw, now_ns=0)
    except MessageValidationError as exc:
        assert str(exc).startswith(spec.name)


OP_NAMES = st.sampled_from([*sorted(ops.MODELS), "auth", ""])
OP_FIELDS = st.sampled_from(
    [
        "id",
        "topic",
        "type",
        "msg",
        "args",
        "values",
        "service",
        "action",
        "result",
        "status",
        "throttle_rate",
        "fragment_size",
        "num",
        "total",
        "data",
        "level",
        "timeout",
        "feedback",
    ]
)


@PROPERTY_SETTINGS
@given(st.dictionaries(OP_FIELDS, JSON_VALUES, max_size=6), OP_NAMES)
def test_any_object_either_parses_or_raises_a_one_line_op_error(fields, op):
    try:
        model = ops.parse_op({**fields, "op": op})
    except ops.OpError as exc:
        assert "\n" not in str(exc)
    else:
        assert ops.to_wire(model)["op"] == op
