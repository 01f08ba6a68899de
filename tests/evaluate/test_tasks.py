"""Evaluation tasks: Stone's grid (Table 7-1, 7.2.1) and the ISO 9283 cube."""

import numpy as np
import pytest

from armcal.procedures.tasks import grid_task, iso9283_cube


def test_grid_lines_have_stones_lengths():
    P = grid_task()[:, :3, 3] / 10.0  # cm
    length = lambda a, b: np.linalg.norm(P[a - 1] - P[b - 1])  # noqa: E731
    assert [length(1, 2), length(3, 4), length(5, 6), length(7, 8)] == [60.0] * 4  # lines along X
    assert [length(1, 3), length(2, 4), length(5, 7), length(6, 8)] == [30.0] * 4  # along Y
    assert [length(1, 5), length(2, 6), length(3, 7), length(4, 8)] == [50.0] * 4  # along Z
    assert np.allclose(P[8], (P[0] + P[1]) / 2) and np.allclose(P[11], (P[6] + P[7]) / 2)  # 9-12 midpoints


def test_grid_orientation_is_rot_y180_rot_z90():
    R = grid_task()[0, :3, :3]
    assert np.allclose(R, [[0, 1, 0], [1, 0, 0], [0, 0, -1]], atol=1e-15)


def test_iso9283_points_lie_on_the_diagonal_plane_at_ten_percent_from_the_corners():
    centre, side = np.array([500.0, 100.0, 600.0]), 400.0
    P = iso9283_cube(centre, side)[:, :3, 3]
    assert np.allclose(P[0], centre)
    diagonal = side * np.sqrt(3)  # the plane's diagonal runs corner to corner through the cube
    for point in P[1:]:
        assert np.linalg.norm(point - centre) == pytest.approx(0.4 * diagonal)
        assert (point - centre)[0] == pytest.approx((point - centre)[1])  # plane x = y through the centre


def test_grid_indices_of_known_distortions():
    from armcal.evaluate.grid import grid_indices

    desired = grid_task()
    assert len(grid_indices(desired, desired)) == 34
    assert max(abs(v) for v in grid_indices(desired, desired).values()) < 1e-9
    stretched = desired.copy()
    stretched[:, :3, 3] *= 1.001  # every length 0.1 % long, shapes and angles kept
    indices = grid_indices(stretched, desired)
    assert indices["line 1 length"] == pytest.approx(0.6)  # 600 mm line
    assert indices["line 9 length"] == pytest.approx(0.5)  # 500 mm along Z
    assert abs(indices["X-Y perpendicularity"]) < 1e-9 and indices["line 1 normal deviation"] < 1e-9
    sheared = desired.copy()
    sheared[:, 0, 3] += 0.002 * sheared[:, 1, 3]  # x leans with y: X-Y no longer square
    assert indices["vertex 4 radial"] == pytest.approx(np.linalg.norm(desired[3, :3, 3]) * 0.001)
    assert grid_indices(sheared, desired)["X-Y perpendicularity"] == pytest.approx(-0.002, rel=1e-3)
