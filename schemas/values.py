"""Names for the values that cross the wire without a static type of their own.

A rosbridge frame is arbitrary JSON (or CBOR) until something checks it: the op models
(`schemas.ops`) check the envelope, the message normaliser (`schemas.message`) checks a
payload against its ROS type. Before and between those checks a value really can be
anything a decoder produces, so these aliases are `Any`, named for what they hold; use a
real type wherever one exists.
"""

from __future__ import annotations

from typing import Any, TypeAlias

#: What a JSON or CBOR decoder produced: a dict, list, str, int, float, bool, None, and from
#: CBOR also bytes and typed arrays (numpy). Not checked yet, or relayed as it came.
JsonValue: TypeAlias = Any
#: A decoded JSON object (an op, or a payload not yet checked against its type).
JsonObject: TypeAlias = dict[str, JsonValue]
#: A message in canonical form (`schemas.message.normalize`): field name -> value, where a
#: value is a scalar, bytes, an ndarray, a nested message or a list of them.
Message: TypeAlias = dict[str, Any]
#: An op's `id` as the bridge accepts it (`schemas.ops`): echoed back in answers.
OpId: TypeAlias = str | int | float | None
