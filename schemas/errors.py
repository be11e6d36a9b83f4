"""One exception tree for everything the schemas layer can reject.

Callers catch :class:`SchemaError` to handle any of them; the subclasses say which
kind of input was wrong so the bridge can log one precise line.
"""

from __future__ import annotations


class SchemaError(Exception):
    """Base of every error raised by :mod:`schemas`."""


class InvalidTypeNameError(SchemaError, ValueError):
    """A type string that is not ``pkg/Type`` or ``pkg/kind/Type`` (``"bad"``, ``"/x"``)."""


class UnknownTypeError(SchemaError, KeyError):
    """A well-formed type name that is not registered."""

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0]) if self.args else ""


class MessageValidationError(SchemaError, ValueError):
    """A message that does not fit its type; the text names the type and the field path."""


class DecodeError(SchemaError, ValueError):
    """A frame that is not valid JSON, CBOR, CDR or PNG."""


class EncodeError(SchemaError, ValueError):
    """A value that cannot be written in the requested encoding (e.g. an int above 2**64)."""
