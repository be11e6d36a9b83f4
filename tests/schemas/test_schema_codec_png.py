import base64
import io
import math

import pytest
from PIL import Image

from schemas import codec_json, frames
from schemas.codec_png import decode_png_data, encode_png_op, png_shape
from schemas.errors import DecodeError


def _image(frame: bytes) -> Image.Image:
    op = codec_json.loads(frame)
    assert list(op) == ["op", "data"] and op["op"] == "png"
    return Image.open(io.BytesIO(base64.b64decode(op["data"])))


@pytest.mark.parametrize("num_bytes", [3, 4, 25, 547, 10_000, 1_280_001])
def test_size_rule_of_rosbridge(num_bytes):
    height, width = png_shape(num_bytes)
    assert width == math.floor(math.sqrt(num_bytes / 3))
    assert height == math.ceil((num_bytes / 3) / width)
    assert height * width * 3 >= num_bytes


def test_round_trip_and_pixels_are_rgb_text():
    text = frames.publish_json("/chatter", {"data": "hello world " * 40})
    frame = encode_png_op(text)
    image = _image(frame)
    height, width = png_shape(len(text))
    assert image.mode == "RGB" and image.size == (width, height)
    pixels = image.tobytes()  # decoded by PIL, independent of OpenCV
    assert pixels[: len(text)] == text
    assert set(pixels[len(text) :]) <= {ord("\n")}
    assert decode_png_data(codec_json.loads(frame)["data"]) == text


def test_large_message_round_trip():
    text = frames.publish_json("/map", {"data": "water " * 200_000})
    frame = encode_png_op(text)
    assert len(frame) < len(text)  # repeated content compresses
    assert decode_png_data(codec_json.loads(frame)["data"]) == text


def test_tiny_input_does_not_divide_by_zero():
    assert decode_png_data(codec_json.loads(encode_png_op(b"{}"))["data"]) == b"{}"


@pytest.mark.parametrize("bad", ["not base64!", base64.b64encode(b"not a png").decode()])
def test_bad_png_data(bad):
    with pytest.raises(DecodeError):
        decode_png_data(bad)
