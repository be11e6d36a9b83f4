"""The message-type registry: standard ROS 2 types from rosbags plus our own definition files.

One :class:`TypeRegistry` per process part (bridge, client) holds a private rosbags
``Typestore`` (for CDR) and the service/action tables that rosbags does not have. Specs are
built on first use and cached on the instance.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.interfaces.typing import BaseDesc, FieldDesc, NameDesc, Typesdict
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.base import TypesysError
from rosbags.typesys.store import Typestore

from schemas import primitives, specs
from schemas.errors import InvalidTypeNameError, SchemaError, UnknownTypeError
from schemas.interface_files import InterfaceSet, load_directory
from schemas.rosapi_defs import TypeDef, message_typedefs
from schemas.specs import ActionSpec, ArrayKind, FieldSpec, MessageSpec, ServiceSpec
from schemas.typenames import normalize_type_name, short_type_name

__all__ = [
    "BUILTIN_INTERFACES_DIR",
    "ActionSpec",
    "FieldSpec",
    "MessageSpec",
    "ServiceSpec",
    "TypeRegistry",
]

logger = logging.getLogger(__name__)

#: Definition files shipped with riverbridge (std_srvs, rosapi_msgs, riverbridge_msgs, ...).
BUILTIN_INTERFACES_DIR = Path(__file__).resolve().parent / "interfaces"

_ARRAY_KIND: dict[Nodetype, ArrayKind] = {Nodetype.ARRAY: "fixed", Nodetype.SEQUENCE: "sequence"}


#: rosbags gives a message without fields this member (ROS 2 IDL forbids empty structs); it is
#: a CDR detail, so specs leave it out and clients see ``{}`` as rosbridge sends it.
EMPTY_MESSAGE_PLACEHOLDER = "structure_needs_at_least_one_member"


class TypeRegistry:
    """Known message, service and action types, under both ``pkg/Type`` spellings."""

    def __init__(self, typestore: Typestore | None = None) -> None:
        """Wrap ``typestore`` (default: a fresh Jazzy store); nothing of ours registered yet."""
        self.typestore = typestore if typestore is not None else get_typestore(Stores.ROS2_JAZZY)
        self._services: dict[str, tuple[str, str]] = {}
        self._actions: dict[str, tuple[str, str, str]] = {}
        self._specs: dict[str, MessageSpec] = {}
        self._full_texts: dict[str, str] = {}  # rosapi asks for the same texts every few s
        self._short_names: dict[str, str] = {}
        self._index_short_names(self.typestore.fielddefs)

    @classmethod
    def with_defaults(cls, extra_dirs: Sequence[Path] = ()) -> TypeRegistry:
        """Jazzy's standard messages, riverbridge's shipped interfaces, then ``extra_dirs``."""
        registry = cls()
        registry.add_directory(BUILTIN_INTERFACES_DIR)
        for folder in extra_dirs:
            registry.add_directory(Path(folder))
        return registry

    # -- loading ------------------------------------------------------------------------------

    def add_directory(self, root: Path) -> None:
        """Register every ``<pkg>/{msg,srv,action}/<Type>.<ext>`` below ``root``.

        Raises :class:`SchemaError` for a file that does not parse, a type already registered
        with a different definition, or a reference to a type nobody defines.
        """
        self.add_interfaces(load_directory(Path(root)))
        logger.debug("registered interfaces from %s", root)

    def add_interfaces(self, found: InterfaceSet) -> None:
        """Register parsed definitions (see :mod:`schemas.interface_files`)."""
        self._check_references(found.types)
        try:
            self.typestore.register(found.types)
        except TypesysError as exc:
            raise SchemaError(str(exc)) from exc
        self._services.update(found.services)
        self._actions.update(found.actions)
        self._index_short_names(found.types)

    def _check_references(self, types: Typesdict) -> None:
        for name, (_consts, fields) in types.items():
            for field_name, node in fields:
                ref = _referenced_type(node)
                if ref and ref not in types and ref not in self.typestore.fielddefs:
                    raise UnknownTypeError(
                        f"{name} field '{field_name}' refers to unknown type {ref}"
                    )

    def _index_short_names(self, names: Iterable[str]) -> None:
        for name in names:
            self._short_names.setdefault(short_type_name(name), name)

    # -- lookup -------------------------------------------------------------------------------

    def _resolve_message_name(self, name: str) -> str:
        full = normalize_type_name(name, "msg")
        if full in self.typestore.fielddefs:
            return full
        if sum(1 for part in name.split("/") if part) == 2:  # 'pkg/T' of a srv/action part
            alias = self._short_names.get(short_type_name(full))
            if alias is not None:
                return alias
        raise UnknownTypeError(f"unknown message type {name!r}")

    def message(self, name: str) -> MessageSpec:
        """The spec of a message type; both spellings; raises Invalid/UnknownTypeError."""
        spec = self._specs.get(name)
        if spec is None:
            full = self._resolve_message_name(name)
            spec = self._specs.get(full) or self._build_message(full)
            if name == short_type_name(full):
                # Cache the two regular spellings only: clients choose the strings we see.
                self._specs[name] = spec
        return spec

    def service(self, name: str) -> ServiceSpec:
        """The spec of ``pkg/srv/T`` (or ``pkg/T``)."""
        full = _service_name(name)
        parts = self._services.get(full)
        if parts is None:
            raise UnknownTypeError(f"unknown service type {name!r}")
        return ServiceSpec(full, self.message(parts[0]), self.message(parts[1]))

    def action(self, name: str) -> ActionSpec:
        """The spec of ``pkg/action/T`` (or ``pkg/T``)."""
        full = _with_kind(name, "action")
        parts = self._actions.get(full)
        if parts is None:
            raise UnknownTypeError(f"unknown action type {name!r}")
        return ActionSpec(full, *(self.message(part) for part in parts))

    def has_message(self, name: object) -> bool:
        return _never_raises(self._resolve_message_name, name)

    def has_service(self, name: object) -> bool:
        return _never_raises(lambda n: self._services[_service_name(n)], name)

    def has_action(self, name: object) -> bool:
        return _never_raises(lambda n: self._actions[_with_kind(n, "action")], name)

    def message_names(self) -> list[str]:
        return sorted(self.typestore.fielddefs)

    def service_names(self) -> list[str]:
        return sorted(self._services)

    def action_names(self) -> list[str]:
        return sorted(self._actions)

    # -- rosapi -------------------------------------------------------------------------------

    def full_text(self, name: str) -> str:
        """ROS 2 gendeps-style definition for ``/rosapi/topics_and_raw_types``.

        The type's own definition, then per dependency a line of 80 ``=``, ``MSG: pkg/Type``
        and its definition; ROS 2 spelling (``builtin_interfaces/Time stamp``).
        """
        full = self._resolve_message_name(name)
        text = self._full_texts.get(full)
        if text is None:
            try:
                text, _md5 = self.typestore.generate_msgdef(full, ros_version=2)
            except AssertionError as exc:  # rosbags writes only `/msg/` types' (not actions')
                raise UnknownTypeError(f"no definition text for {full}") from exc
            self._full_texts[full] = text
        return text

    def typedefs(self, name: str) -> list[TypeDef]:
        """rosapi ``TypeDef`` dicts: the requested type first, then nested types, recursively."""
        return message_typedefs(self.message(name))

    # -- spec construction --------------------------------------------------------------------

    def _build_message(self, full: str) -> MessageSpec:
        consts, fields = self.typestore.fielddefs[full]
        spec = MessageSpec(
            name=full,
            fields=tuple(
                self._field_spec(full, fname, node)
                for fname, node in fields
                if fname != EMPTY_MESSAGE_PLACEHOLDER
            ),
            constants=tuple((cname, ctype, value) for cname, ctype, value in consts),
        )
        self._specs[full] = spec
        return spec

    def _field_spec(self, owner: str, name: str, node: FieldDesc) -> FieldSpec:
        element, array, length = _element(node)
        if element[0] == Nodetype.NAME:
            type_name = element[1]
            return FieldSpec(
                name=name,
                base=type_name,
                is_message=True,
                array=array,
                length=length,
                default=None,
                message=self.message(type_name),
                category=specs.MESSAGE_ARRAY if array else specs.MESSAGE,
            )
        base, string_bound = element[1]
        category = _primitive_category(base, array)
        dtype = primitives.NUMERIC_DTYPES.get(base)
        return FieldSpec(
            name=name,
            base=base,
            is_message=False,
            array=array,
            length=length,
            default=primitives.DECLARED_DEFAULTS.get(
                (owner, name), _primitive_default(base, array, length, category, dtype)
            ),
            message=None,
            category=category,
            dtype=dtype,
            string_bound=string_bound,
        )


def _element(node: FieldDesc) -> tuple[BaseDesc | NameDesc, ArrayKind, int]:
    """A field's element type, its array kind (None: a single value) and array length."""
    if node[0] == Nodetype.ARRAY or node[0] == Nodetype.SEQUENCE:
        element, length = node[1]
        array = _ARRAY_KIND[node[0]]
        if array == "sequence" and length:
            array = "bounded"
        return element, array, length
    return node, None, 0


def _referenced_type(node: FieldDesc) -> str | None:
    element, _array, _length = _element(node)
    return element[1] if element[0] == Nodetype.NAME else None


def _with_kind(name: str, kind: str) -> str:
    """``pkg/T`` or ``pkg/any/T`` -> ``pkg/<kind>/T``."""
    full = normalize_type_name(name, kind)  # type: ignore[arg-type]
    pkg, _middle, leaf = full.split("/")
    return f"{pkg}/{kind}/{leaf}"


def _service_name(name: str) -> str:
    """`pkg/srv/T`; an action's own services (`pkg/action/T_SendGoal`) keep their kind."""
    return name if name.count("/") == 2 and "/action/" in name else _with_kind(name, "srv")


def _never_raises(lookup: Callable[[str], object], name: object) -> bool:
    if not isinstance(name, str):
        return False
    try:
        lookup(name)
    except (InvalidTypeNameError, UnknownTypeError, KeyError):
        return False
    return True


_SCALAR_CATEGORY = {"bool": specs.BOOL, "string": specs.STRING, "wstring": specs.STRING}


def _primitive_category(base: str, array: str | None) -> str:
    if array is None:
        if base in primitives.INT_DTYPES:
            return specs.INT
        if base in primitives.FLOAT_DTYPES:
            return specs.FLOAT
        return _SCALAR_CATEGORY[base]
    if base in primitives.OCTET_TYPES:
        return specs.BYTES
    if base in primitives.NUMERIC_DTYPES:
        return specs.NUMERIC_FIXED if array == "fixed" else specs.NUMERIC_SEQUENCE
    return specs.BOOL_ARRAY if base == "bool" else specs.STRING_ARRAY


def _primitive_default(
    base: str, array: ArrayKind, length: int, category: str, dtype: np.dtype[Any] | None
) -> object:
    if array is None:
        return primitives.scalar_default(base)
    fixed_length = length if array == "fixed" else 0
    if category == specs.BYTES:
        return bytes(fixed_length)
    if category == specs.NUMERIC_SEQUENCE:
        empty = np.empty(0, dtype=dtype)
        empty.flags.writeable = False
        return empty
    return [primitives.scalar_default(base)] * fixed_length
