"""Bounding-box refinement (thesis 3.5.3, figures 17 and 18)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from navigation.boxes import halving_levels, refine_boxes


def test_halving_levels_match_repeated_halving():
    extents = np.array([0.0, 2.9, 3.0, 5.9, 6.0, 12.0, 12.1, 100.0])
    expected = []
    for extent in extents:
        k = 0
        while extent / 2**k >= 3.0:
            k += 1
        expected.append(k)
    assert halving_levels(extents, 3.0).tolist() == expected


def test_small_cluster_keeps_its_own_box():
    xyz = np.array([[0, 0, 0], [1, 2, 0.5], [2, 1, 1]], np.float32)
    boxes = refine_boxes(xyz, np.zeros(3, np.int32), 3.0)
    assert len(boxes) == 1
    np.testing.assert_array_equal(boxes.min_xyz[0], [0, 0, 0])
    np.testing.assert_array_equal(boxes.max_xyz[0], [2, 2, 1])
    assert boxes.num_points.tolist() == [3]


def test_l_shaped_cluster_drops_the_empty_quarter():
    """Thesis figure 18: of the four halves of an L-shaped cluster's box, the empty one goes."""
    leg_x = np.column_stack([np.linspace(0, 4, 41), np.zeros(41), np.zeros(41)])
    leg_y = np.column_stack([np.zeros(41), np.linspace(0, 4, 41), np.zeros(41)])
    xyz = np.vstack([leg_x, leg_y]).astype(np.float32)
    boxes = refine_boxes(xyz, np.zeros(len(xyz), np.int32), 3.0)
    assert len(boxes) == 3
    occupied = {tuple(lo[:2]) for lo in boxes.min_xyz.tolist()}
    assert occupied == {(0.0, 0.0), (2.0, 0.0), (0.0, 2.0)}
    assert np.all(boxes.size_xyz[:, :2] <= 2.0 + 1e-6)


def test_shrink_tightens_boxes_to_their_points():
    xyz = np.array([[0, 0, 0], [0.5, 0.5, 0], [8, 0.2, 0.1]], np.float32)
    boxes = refine_boxes(xyz, np.zeros(3, np.int32), 3.0, shrink=True)
    assert len(boxes) == 2
    order = np.argsort(boxes.min_xyz[:, 0])
    np.testing.assert_array_equal(boxes.max_xyz[order[0]], [0.5, 0.5, 0])
    np.testing.assert_array_equal(boxes.min_xyz[order[1]], boxes.max_xyz[order[1]])


def test_noise_only_gives_no_boxes():
    assert len(refine_boxes(np.zeros((4, 3), np.float32), np.full(4, -1), 3.0)) == 0


clouds = st.integers(1, 400).flatmap(
    lambda n: st.tuples(
        arrays(np.float32, (n, 3), elements=st.floats(-40, 40, width=32)),
        arrays(np.int32, (n,), elements=st.integers(-1, 5)),
    )
)


@settings(max_examples=60, deadline=None)
@given(clouds, st.sampled_from([0.5, 3.0, 7.0]), st.booleans())
def test_boxes_bound_every_point_and_respect_the_size_limit(cloud, max_size_m, shrink):
    xyz, labels = cloud
    boxes = refine_boxes(xyz, labels, max_size_m, shrink)
    clustered = labels >= 0
    assert int(boxes.num_points.sum()) == int(clustered.sum())
    assert np.all(boxes.num_points > 0)
    assert np.all(boxes.size_xyz < max_size_m + 1e-5 * max_size_m)
    if not clustered.any():
        return
    pts, lab = xyz[clustered], labels[clustered]
    inside = ((pts[:, None] >= boxes.min_xyz[None]) & (pts[:, None] <= boxes.max_xyz[None])).all(2)
    assert np.all((inside & (lab[:, None] == boxes.cluster_id[None])).any(axis=1))
    assert set(boxes.cluster_id.tolist()) == set(lab.tolist())


@pytest.mark.parametrize("extent_m", [2.99, 3.0, 9.0])
def test_every_box_is_strictly_below_the_limit(extent_m):
    xyz = np.column_stack([np.linspace(0, extent_m, 200), np.zeros(200), np.zeros(200)])
    boxes = refine_boxes(xyz.astype(np.float32), np.zeros(200, np.int32), 3.0)
    assert np.all(boxes.size_xyz < 3.0)
