"""rosbridge's ``png`` compression (protocol reference §2.11), with OpenCV's PNG encoder.

The JSON text of a whole ``publish`` op (N bytes) is padded with ``\\n`` to
``width * height * 3`` bytes, where ``width = floor(sqrt(N / 3))`` and
``height = ceil((N / 3) / width)``, read row-major as an 8-bit RGB image, stored as PNG and
sent base64-encoded in ``{"op":"png","data":...}``. OpenCV stores pixels as BGR, so the
channel order is reversed on the way in and out.
"""

from __future__ import annotations

import binascii
import math
from types import ModuleType

import numpy as np
import pybase64

from schemas.errors import DecodeError, EncodeError

_PAD = b"\n"


def _cv2() -> ModuleType:
    """OpenCV, imported on the first PNG: it adds ~20 MiB to every process that loads this
    module (the bridge's idle RSS 80 -> 60 MiB), and few clients ask for png."""
    import cv2

    return cv2


def png_shape(num_bytes: int) -> tuple[int, int]:
    """``(height, width)`` of the image that holds ``num_bytes`` of text (at least 1 x 1)."""
    width = max(1, math.floor(math.sqrt(num_bytes / 3)))
    height = max(1, math.ceil((num_bytes / 3) / width))
    return height, width


def encode_png_data(json_text: bytes) -> bytes:
    """Base64 (ASCII bytes) of the PNG that carries ``json_text``."""
    height, width = png_shape(len(json_text))
    padded = json_text.ljust(height * width * 3, _PAD)
    rgb = np.frombuffer(padded, dtype=np.uint8).reshape(height, width, 3)
    ok, png = _cv2().imencode(".png", np.ascontiguousarray(rgb[:, :, ::-1]))
    if not ok:
        raise EncodeError("OpenCV could not encode the PNG")
    return pybase64.b64encode(png.tobytes())


def encode_png_op(json_text: bytes) -> bytes:
    """The whole text frame ``{"op":"png","data":"<base64 png>"}`` for one JSON op."""
    return b'{"op":"png","data":"' + encode_png_data(json_text) + b'"}'


def decode_png_data(data_b64: str) -> bytes:
    """The original JSON text from a ``png`` op's ``data`` (``\\n`` padding stripped)."""
    try:
        png = pybase64.b64decode(data_b64, validate=True)
    except (binascii.Error, ValueError):
        raise DecodeError("png data is not base64") from None
    cv2 = _cv2()
    image = cv2.imdecode(np.frombuffer(png, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None or image.ndim != 3 or image.shape[2] != 3:
        raise DecodeError("png data is not a 3-channel PNG image")
    return np.ascontiguousarray(image[:, :, ::-1]).tobytes().rstrip(_PAD)
