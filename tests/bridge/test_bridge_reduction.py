"""Point clouds thinned to fit the link (bridge.reduction): one point per voxel with all its
fields, a budget met by the smallest voxel that fits, and what was done said in the op."""

from __future__ import annotations

import numpy as np
import pytest

from bridge.reduction import (
    VOXEL_LADDER_M,
    CloudReducer,
    ReduceRequest,
    budget_for_link,
    first_per_voxel,
)
from schemas import codec_cbor
from schemas.pointcloud import pack_points, view_points


def cloud(points: np.ndarray) -> dict:
    return pack_points(points.astype(np.float32), 0, "lidar")


def grid_points(step_m: float, extent_m: float) -> np.ndarray:
    """(n, 4): a flat grid of x, y at `step_m` over `extent_m`, z 0, intensity = index."""
    axis = np.arange(0.0, extent_m, step_m) + step_m / 2
    x, y = np.meshgrid(axis, axis)
    n = x.size
    return np.column_stack([x.ravel(), y.ravel(), np.zeros(n), np.arange(n)])


def test_one_point_per_voxel_the_first_in_scan_order_nan_ignored():
    xyz = np.array([[0.1, 0.1, 0], [0.2, 0.2, 0], [np.nan, 0, 0], [1.5, 0.1, 0], [0.3, 0.4, 0]])
    msg = cloud(np.column_stack([xyz, np.arange(5)]))
    reduced, said = CloudReducer(msg).reduced(1.0)
    points = view_points(reduced)
    assert said.points_in == 5 and said.points_kept == 2 and said.voxel_size_m == 1.0
    np.testing.assert_array_equal(points[:, 3], [0, 3])  # intensity travels with its point
    assert reduced["width"] == 2 and reduced["row_step"] == 2 * reduced["point_step"]
    assert len(reduced["data"]) == 2 * reduced["point_step"]


def test_matches_a_plain_unique_on_a_large_cloud():
    rng = np.random.default_rng(1)
    xyz = rng.normal(0, 20, (50_000, 3)).astype(np.float32)
    kept = first_per_voxel(np.ascontiguousarray(xyz.T), 0.5)
    keys = np.floor(xyz / np.float32(0.5)).astype(np.int64)
    keys -= keys.min(axis=0)
    _, first = np.unique((keys[:, 0] * 10**6 + keys[:, 1]) * 10**6 + keys[:, 2], return_index=True)
    np.testing.assert_array_equal(kept, np.sort(first))


def test_a_budget_takes_the_smallest_ladder_voxel_that_fits():
    msg = cloud(grid_points(0.05, 20.0))  # 160,000 points, 5 cm apart
    reducer = CloudReducer(msg)
    voxel = reducer.voxel_for(ReduceRequest(point_budget=10_000), None)
    assert voxel is not None
    _, said = reducer.reduced(voxel)
    assert said.points_kept <= 10_000
    smaller = VOXEL_LADDER_M[VOXEL_LADDER_M.index(voxel) - 1]
    assert reducer.kept(smaller).size > 10_000
    # a cloud that fits, or an unmeasured link, is sent whole
    assert reducer.voxel_for(ReduceRequest(point_budget=200_000), None) is None
    assert reducer.voxel_for(ReduceRequest(point_budget="auto"), None) is None


def test_auto_budgets_a_fifth_of_a_second_of_the_link():
    assert budget_for_link(1_250_000, 16) == 15_625  # 10 Mbit/s, x y z intensity
    assert budget_for_link(None, 16) is None


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ({}, "exactly one"),
        ({"voxel_size": 0.2, "point_budget": 10}, "exactly one"),
        ({"voxel_size": -1}, "positive number"),
        ({"voxel_size": True}, "positive number"),
        ({"point_budget": "lots"}, "positive integer or 'auto'"),
        ({"voxel": 0.2}, "unknown keys"),
    ],
)
def test_a_bad_request_names_the_problem(value, problem):
    with pytest.raises(ValueError, match=problem):
        ReduceRequest.from_op(value)


def test_a_cloud_without_float_xyz_is_sent_whole():
    msg = cloud(grid_points(1.0, 4.0))
    msg["fields"][0]["datatype"] = 8  # FLOAT64
    assert CloudReducer(msg).voxel_for(ReduceRequest(voxel_size_m=1.0), None) is None


def test_the_subscriber_gets_the_reduced_cloud_and_what_was_done(harness):
    publisher, subscriber = harness.connect(), harness.connect()
    harness.send(
        publisher,
        {"op": "advertise", "topic": "/lidar/points", "type": "sensor_msgs/msg/PointCloud2"},
    )
    harness.send(
        subscriber,
        {
            "op": "subscribe",
            "topic": "/lidar/points",
            "compression": "cbor",
            "reduce": {"voxel_size": 1.0},
        },
    )
    msg = cloud(grid_points(0.25, 4.0))  # 256 points, 16 per 1 m voxel
    harness.send(
        publisher, codec_cbor.dumps({"op": "publish", "topic": "/lidar/points", "msg": msg})
    )
    [op] = harness.outbox(subscriber)
    assert op["reduced"] == {"voxel_size_m": 1.0, "points_in": 256, "points_kept": 16}
    assert op["msg"]["width"] == 16


def test_reduce_on_another_type_is_ignored_with_a_warning(harness, caplog):
    client = harness.connect()
    harness.send(client, {"op": "advertise", "topic": "/chat", "type": "std_msgs/msg/String"})
    harness.send(client, {"op": "subscribe", "topic": "/chat", "reduce": {"voxel_size": 1.0}})
    assert "reduce applies to sensor_msgs/msg/PointCloud2, not std_msgs/msg/String" in caplog.text
    harness.send(client, {"op": "subscribe", "topic": "/chat", "reduce": {"voxel_size": "big"}})
    assert "reduce: voxel_size must be a positive number" in caplog.text
