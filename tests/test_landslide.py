"""The landslide measure of a failing slope (timpm/studies/landslide.py): the front of the
deposit, the scarp, the retrogressions counted from the frames, and its way into a scene
file's JSON."""
import json

import numpy as np
import pytest

from timpm.studies.landslide import Landslide


def test_the_front_is_the_last_column_of_standing_soil_and_the_scarp_the_moved_soils_rear():
    slide = Landslide(toe=4.0, height=2.0)
    x0 = np.array([[0.5, 0.5], [1.5, 0.5], [2.5, 0.5], [3.5, 0.2]])
    x = x0 + np.array([[0.0, 0.0], [0.0, 0.0], [1.0, -0.2], [2.0, -0.1]])
    frame = slide.observe(x0, x, h=1.0)
    # the soil at x = 5.5 stands 0.1 m > 2 % of H: its column [5, 6) is the front
    assert frame == {"front": 6.0, "scarp": 2.5}
    assert np.isnan(slide.observe(x0, x0, h=1.0)["scarp"])  # nothing moved


@pytest.mark.parametrize("scarp, retrogressions, retreat", [
    ([np.nan, 15.0, 15.0, 15.0], 1, 0.0),                 # one slide, at once
    ([np.nan, 15.0, 14.0, 13.0, 12.0, 12.0], 1, 3.0),     # one slide growing back
    ([np.nan, 15.0, 15.0, 10.0, 10.0, 10.0, 5.0], 3, 10.0),  # three blocks, one by one
    ([np.nan, 15.0, 15.2, 14.9, 15.0], 1, 0.1),           # less than a cell: no new block
])
def test_retrogressions_are_the_steps_back_of_the_scarp(scarp, retrogressions, retreat):
    out = Landslide(toe=20.0, height=10.0).summary(
        {"front": [20.0, 26.0, 31.0], "scarp": scarp}, h=0.5)
    assert out["retrogressions"] == retrogressions
    assert out["scarp_retreat"] == pytest.approx(retreat)
    assert out["runout"] == 11.0 and out["runout_over_H"] == pytest.approx(1.1)
    # a slope that never moved: no slide
    assert Landslide(20.0, 10.0).summary({"front": [20.0], "scarp": [np.nan]},
                                         h=0.5)["retrogressions"] == 0


@pytest.mark.parametrize("toe, height", [(float("nan"), 1.0), (0.0, 0.0), (True, 1.0)])
def test_a_bad_slope_is_refused(toe, height):
    with pytest.raises(ValueError, match="landslide: (toe|height) must be a finite number"):
        Landslide(toe=toe, height=height)


def test_a_scene_files_landslide_reaches_its_json(tmp_path):
    """[output.landslide] of Griffiths & Lane's slope with its strength reduced well past
    its factor of safety: it slides out beyond the toe, and the JSON says how far."""
    from pathlib import Path

    from timpm.scenefile import run_scene, load_scene

    path = Path(__file__).resolve().parent.parent / "examples" / "slope_griffiths_lane.toml"
    out = tmp_path / "slope.json"
    scene = load_scene(path, {"domain.cells": 60, "material.soil.cohesion": 4000.0,
                              "material.soil.friction_angle": 10.0, "simulation.damping": 0.0,
                              "simulation.t_end": 3.0, "output.json": str(out),
                              "output.frames": 10,
                              "output.landslide": {"toe": 40.0, "height": 10.0}})
    result = run_scene(scene)
    doc = json.loads(out.read_text())
    slide = doc["landslide"]
    assert slide == result.summary["landslide"]
    assert slide["runout"] > 2.0 and slide["retrogressions"] >= 1
    assert 0.0 < slide["scarp_retreat"] < 20.0  # behind the toe, within the crest
    assert len(doc["series"]["front"]) == 11
    with pytest.raises(ValueError, match=r"output.landslide \(overridden\): missing required "
                                         r"key 'height'"):
        load_scene(path, {"output.landslide": {"toe": 40.0}})
