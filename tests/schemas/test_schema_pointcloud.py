"""PointCloud2 <-> (n, k) float32: packed in one copy, viewed without one (schemas.pointcloud)."""

from __future__ import annotations

import numpy as np
import pytest

from schemas.pointcloud import LAYOUTS, XYZ, XYZI, PointCloudLayoutError, pack_points, view_points


def test_round_trip_shares_the_payload():
    points = np.arange(40, dtype=np.float32).reshape(10, 4)
    msg = pack_points(points, 5, "lidar")
    view = view_points(msg)
    np.testing.assert_array_equal(view, points)
    assert np.shares_memory(view, np.frombuffer(msg["data"], np.uint8))
    assert not view.flags.writeable  # a view of immutable bytes


def test_padded_point_step_becomes_a_strided_view():
    padded = np.zeros((5, 8), np.float32)
    padded[:, :4] = np.arange(20).reshape(5, 4)
    msg = pack_points(padded[:, :4], 0, "lidar")
    msg.update(point_step=32, row_step=160, data=padded.tobytes())
    np.testing.assert_array_equal(view_points(msg), padded[:, :4])


@pytest.mark.parametrize(
    "change, problem",
    [
        (lambda m: m["fields"].pop(), "lacks"),
        (lambda m: m["fields"][1].update(datatype=8), "consecutive"),
        (lambda m: m.update(is_bigendian=True), "big-endian"),
        (lambda m: m.update(width=11), "holds"),
    ],
)
def test_unsupported_layouts_are_named(change, problem):
    msg = pack_points(np.zeros((10, 4), np.float32), 0, "lidar")
    change(msg)
    with pytest.raises(PointCloudLayoutError, match=problem):
        view_points(msg)


def test_pack_drops_columns_beyond_the_fields_and_stamps_the_header():
    points = np.arange(40, dtype=np.float32).reshape(10, 4)
    msg = pack_points(points, 2_000_000_001, "lidar", XYZ)
    assert msg["header"] == {"stamp": {"sec": 2, "nanosec": 1}, "frame_id": "lidar"}
    assert (msg["point_step"], msg["row_step"], len(msg["data"])) == (12, 120, 120)
    assert [f["name"] for f in msg["fields"]] == ["x", "y", "z"]
    np.testing.assert_array_equal(view_points(msg, XYZ), points[:, :3])
    with pytest.raises(PointCloudLayoutError, match="lacks"):
        view_points(msg)  # no intensity to view


@pytest.mark.parametrize("shape", [(10,), (10, 2), (2, 10, 4)])
def test_pack_names_a_wrong_shape(shape):
    with pytest.raises(ValueError, match=r"\(n, >= 4\)"):
        pack_points(np.zeros(shape, np.float32), 0, "lidar")


def test_layouts_name_the_configured_point_fields():
    assert LAYOUTS == {"xyzi": XYZI, "xyz": XYZ}
