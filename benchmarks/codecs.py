"""Codec timings for one LIDAR scan: a 4 MB PointCloud2 (345,600 points x 16 bytes).

Prints min and median milliseconds of each step of the message path: normalize, JSON
dumps/loads (bytes as base64), CBOR dumps/loads, CDR to/from, PNG. Run as
``python -m benchmarks.codecs``; ``--tuned-malloc`` re-runs itself with glibc malloc
thresholds raised, which removes most of the page-fault cost of fresh 4 MB buffers on this
kind of VM (reference/performance-measurements.md, "Page-fault note").
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable, Sequence

import numpy as np

from benchmarks.malloc import malloc_tuned, rerun_tuned
from schemas import codec_cbor, codec_json, frames
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.codec_png import decode_png_data, encode_png_op
from schemas.message import normalize
from schemas.pointcloud import pack_points
from schemas.registry import TypeRegistry
from schemas.safety import frame_problem

LIDAR_POINTS = 345_600  # thesis LIDAR: 1440 azimuth x 240 elevation rays
POINT_STEP_BYTES = 16  # x, y, z, intensity as float32


def pointcloud(num_points: int) -> dict:
    """A raw PointCloud2 dict holding (num_points, 4) float32 points as bytes."""
    points = np.random.default_rng(0).random((num_points, 4), dtype=np.float32)
    return pack_points(points, 1_700_000_000 * 10**9, "lidar")


def measure(step: Callable[[], object], repeats: int) -> tuple[float, float]:
    """(min, median) wall time of ``step`` in ms, after one warm-up call."""
    step()
    times = []
    for _ in range(repeats):
        start = time.perf_counter_ns()
        step()
        times.append((time.perf_counter_ns() - start) / 1e6)
    return min(times), statistics.median(times)


def run(num_points: int, repeats: int) -> list[tuple[str, float, float, int]]:
    registry = TypeRegistry.with_defaults()
    spec = registry.message("sensor_msgs/msg/PointCloud2")
    raw = pointcloud(num_points)
    msg = normalize(spec, raw, now_ns=0)
    json_frame = frames.publish_json("/lidar", msg)
    json_msg = codec_json.loads(json_frame)["msg"]
    cbor_frame = frames.publish_cbor("/lidar", msg)
    cdr = to_cdr(registry, spec.name, msg)
    png_frame = encode_png_op(json_frame)
    png_data = codec_json.loads(png_frame)["data"]
    json_decoded, cbor_decoded = codec_json.loads(json_frame), codec_cbor.loads(cbor_frame)
    json_envelope = {k: v for k, v in json_decoded.items() if k != "msg"}
    steps = [
        ("normalize (canonical input)", lambda: normalize(spec, raw, now_ns=0), 0),
        ("normalize (from JSON, base64)", lambda: normalize(spec, json_msg, now_ns=0), 0),
        ("json dumps (publish frame)", lambda: frames.publish_json("/lidar", msg), len(json_frame)),
        ("json loads", lambda: codec_json.loads(json_frame), 0),
        ("cbor dumps (publish frame)", lambda: frames.publish_cbor("/lidar", msg), len(cbor_frame)),
        ("cbor loads", lambda: codec_cbor.loads(cbor_frame), 0),
        (
            "cbor loads + normalize",
            lambda: normalize(spec, codec_cbor.loads(cbor_frame)["msg"], now_ns=0),
            0,
        ),
        # The door check the bridge adds to each inbound frame (bridge.inbound.decode_frame):
        # a CBOR frame whole; a JSON frame orjson parsed without its typed `msg`; a JSON frame
        # the lenient parser read (NaN tokens), whole.
        ("door check (CBOR frame)", lambda: frame_problem(cbor_decoded), 0),
        ("door check (strict JSON frame)", lambda: frame_problem(json_envelope), 0),
        ("door check (lenient JSON frame)", lambda: frame_problem(json_decoded), 0),
        ("cdr to", lambda: to_cdr(registry, spec.name, msg), len(cdr)),
        ("cdr from", lambda: from_cdr(registry, spec.name, cdr), 0),
        ("png encode (of the JSON frame)", lambda: encode_png_op(json_frame), len(png_frame)),
        ("png decode", lambda: decode_png_data(png_data), 0),
    ]
    return [(name, *measure(step, repeats), size) for name, step, size in steps]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=LIDAR_POINTS)
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument(
        "--tuned-malloc", action="store_true", help="re-run with raised glibc malloc thresholds"
    )
    args = parser.parse_args(argv)
    if args.tuned_malloc and not malloc_tuned():
        rerun_tuned(__spec__.name, argv if argv is not None else sys.argv[1:])
    tuned = malloc_tuned()
    print(
        f"PointCloud2 {args.points} points x {POINT_STEP_BYTES} B = "
        f"{args.points * POINT_STEP_BYTES / 1e6:.2f} MB; {args.repeats} repeats; "
        f"malloc {'tuned' if tuned else 'default'}"
    )
    print(f"{'step':34s} {'min ms':>8s} {'median ms':>10s} {'output B':>11s}")
    for name, low, median, size in run(args.points, args.repeats):
        print(f"{name:34s} {low:8.2f} {median:10.2f} {size or '':>11}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
