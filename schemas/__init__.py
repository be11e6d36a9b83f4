"""riverbridge's bottom layer: message types, rosbridge ops and codecs, with no I/O.

- :mod:`schemas.typenames`, :mod:`schemas.registry`: type names and the type registry
  (standard ROS 2 messages from rosbags, our ``.msg/.srv/.action`` files in ``interfaces/``).
- :mod:`schemas.message`: JSON/CBOR-decoded input -> the canonical form (docs/messages.md).
- :mod:`schemas.codec_json`, :mod:`schemas.codec_cbor`, :mod:`schemas.codec_cdr`,
  :mod:`schemas.codec_png`, :mod:`schemas.frames`: wire encodings and whole publish frames.
- :mod:`schemas.ops`: every rosbridge op as a pydantic model; :mod:`schemas.errors`: the one
  exception tree.
"""

from schemas.runtime.native import native_first

# The compiled hot path, if built and current (schemas.runtime.native).
__path__ = native_first(__path__, __name__)
