"""Scenes from TOML and from dicts: the same keys, the same checks, errors as exceptions naming the key."""

from __future__ import annotations

import math

import pytest

import flexsurf


def test_from_toml_reads_the_ball_drop(root):
    scene = flexsurf.Scene.from_toml(root / "scenes" / "ball_drop.toml")
    assert scene.name == "ball_drop"
    assert scene.grid == (21, 21)
    assert scene.dt == 0.01 and scene.steps == 300 and scene.output_every == 100
    assert scene.fabric["tensile_warp"] == 21300.0
    assert not scene.is_static


def test_from_dict_matches_from_toml(root):
    path = root / "scenes" / "ball_drop.toml"
    d = flexsurf.scene_dict(path)
    a = flexsurf.Scene.from_toml(path)
    b = flexsurf.Scene.from_dict(d, path)
    assert (a.name, a.grid, a.dt, a.steps, a.fabric, a.total_mass) == (b.name, b.grid, b.dt, b.steps, b.fabric, b.total_mass)


@pytest.mark.parametrize(
    ("override", "key"),
    [
        ({"time.dt": -0.01}, "time.dt"),
        ({"time.dt": math.nan}, "time.dt"),
        ({"obstacle.0.sphere.radius": -1.0}, "obstacle[0].sphere.radius"),
        ({"sheet.nodes": [1, 11]}, "sheet.nodes"),
        ({"contact.friction": "high"}, "contact.friction"),
        ({"time.stepz": 3}, "time"),
        ({"material.bending_warp": -1.0}, "material.bending_warp"),
    ],
)
def test_errors_name_the_key(small_drop, override, key):
    with pytest.raises(flexsurf.SceneError) as info:
        flexsurf.Scene.from_dict(flexsurf.with_overrides(small_drop, override))
    assert key in str(info.value)
    assert key in info.value.key
    assert isinstance(info.value, flexsurf.FlexsurfError)


def test_toml_errors_name_the_key(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[sheet]\nsize = [1.0, 1.0]\nnodes = [11, 11]\n[time]\ndt = 0.0\nsteps = 3\n[material]\npreset = "paper-cotton"\n')
    with pytest.raises(flexsurf.SceneError, match=r"time\.dt"):
        flexsurf.Scene.from_toml(bad)
    with pytest.raises(flexsurf.SceneError, match="cannot read"):
        flexsurf.Scene.from_toml(tmp_path / "missing.toml")


def test_bad_values_in_dicts_raise_type_errors(small_drop):
    d = flexsurf.with_overrides(small_drop, {"time.dt": object()})
    with pytest.raises(TypeError, match=r"time\.dt"):
        flexsurf.Scene.from_dict(d)
    with pytest.raises(TypeError):
        flexsurf.Scene.from_dict({1: 2})


def test_materials_from_files_and_keywords(root):
    denim = flexsurf.Material.from_file(root / "materials" / "denim.toml")
    assert denim.name.startswith("denim") and denim.density > 0
    cotton = flexsurf.Material.from_file(root / "materials" / "paper-cotton.toml")
    kw = flexsurf.Material(**{k: v for k, v in cotton.to_dict().items() if v is not None})
    assert kw.to_dict() == cotton.to_dict()
    stiffer = flexsurf.Material(preset="paper-cotton", bending_warp=1e-3)
    assert stiffer.bending_warp == 1e-3 and stiffer.tensile_warp == 21300.0
    with pytest.raises(flexsurf.SceneError) as info:
        flexsurf.Material(preset="paper-cotton", shear=-2.0)
    assert info.value.key == "shear"
    with pytest.raises(flexsurf.SceneError, match="colour"):
        flexsurf.Material(preset="paper-cotton", colour="red")
