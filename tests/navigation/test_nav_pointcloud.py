"""PointCloud2 <-> (n, 4) float32 without copies."""

from __future__ import annotations

import numpy as np
import pytest

from navigation.pointcloud import PointCloudLayoutError, pointcloud2_msg, xyzi_view


def test_round_trip_shares_the_payload():
    points = np.arange(40, dtype=np.float32).reshape(10, 4)
    msg = pointcloud2_msg(points, 5, "lidar")
    view = xyzi_view(msg)
    np.testing.assert_array_equal(view, points)
    assert np.shares_memory(view, np.frombuffer(msg["data"], np.uint8))
    assert not view.flags.writeable  # a view of immutable bytes


def test_padded_point_step_becomes_a_strided_view():
    padded = np.zeros((5, 8), np.float32)
    padded[:, :4] = np.arange(20).reshape(5, 4)
    msg = pointcloud2_msg(padded[:, :4], 0, "lidar")
    msg.update(point_step=32, row_step=160, data=padded.tobytes())
    np.testing.assert_array_equal(xyzi_view(msg), padded[:, :4])


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
    msg = pointcloud2_msg(np.zeros((10, 4), np.float32), 0, "lidar")
    change(msg)
    with pytest.raises(PointCloudLayoutError, match=problem):
        xyzi_view(msg)
