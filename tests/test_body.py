"""Shapes, sensor layouts and the stable order of readings (docs/original-system.md section 3)."""

from __future__ import annotations

import pytest

from somite.errors import SomiteError
from somite.sim.body import Body, Shape


def test_presets_match_the_paper():
    biped = Shape.parse("biped")
    assert biped.grid_string() == "1111/1111/1001"
    assert biped.n_voxels == 10
    assert (1, 0) not in biped.voxels and (2, 0) not in biped.voxels
    worm = Shape.parse("worm")
    assert (worm.width, worm.height, worm.n_voxels) == (6, 2, 12)


def test_rectangles_and_grids():
    assert Shape.parse("3x2") == Shape.parse("111/111")
    assert Shape.parse("1111/1111/1001") == Shape.parse("biped")
    shape = Shape.parse("010/111")
    assert shape.voxels == ((0, 0), (1, 0), (2, 0), (1, 1))


def test_voxels_are_listed_bottom_row_first():
    assert Shape.parse("biped").voxels[:3] == ((0, 0), (3, 0), (0, 1))


@pytest.mark.parametrize(
    "text, field",
    [("", "shape"), ("0000/0000", "shape"), ("101", "shape"), ("11/1", "shape"),
     ("11/12", "shape"), ("0x3", "shape"), ("1001/1001", "shape")],
)
def test_bad_shapes_name_the_field(text, field):
    with pytest.raises(SomiteError, match=f"^{field}="):
        Shape.parse(text)


def test_paper_sensor_counts():
    assert Body.build("biped").n_readings == 35  # Table 1's 45 nodes - 10 actuators
    assert Body.build("worm").n_readings == 40


def test_reading_order_follows_the_original_layout():
    # docs/original-system.md section 3: worm (5,0) -> a, t, l0..l4; (5,1) -> a, vx, vy, l0..l4
    readings = Body.build("worm").readings
    v50 = Shape.parse("worm").index(5, 0)
    kinds = [(r.kind, r.component) for r in readings if r.voxel == v50]
    assert kinds == [("area", 0), ("touch", 0)] + [("lidar", k) for k in range(5)]
    assert [r.voxel for r in readings] == sorted(r.voxel for r in readings)
    biped = Body.build("biped")
    top_right = biped.shape.index(3, 2)
    kinds = [r.kind for r in biped.readings if r.voxel == top_right]
    assert kinds == ["area", "velocity", "velocity"] + ["lidar"] * 5


def test_custom_sensors_and_round_trip():
    body = Body.build("2x1", {(0, 0): ["touch", "area"], (1, 0): ["lidar"]})
    assert body.sensors == (("area", "touch"), ("lidar",))
    assert Body.from_dict(body.to_dict()) == body
    with pytest.raises(SomiteError, match="^sensor='sonar'"):
        Body.build("2x1", {(0, 0): ["sonar"]})
    with pytest.raises(SomiteError, match="^voxel="):
        Body.build("2x1", {(5, 0): ["area"]})
