"""The virtual textile tests return their reports as dicts, on materials from files or keyword arguments."""

from __future__ import annotations

import pytest

import flexsurf


def test_kes_recovers_the_constants():
    report = flexsurf.kes()
    assert set(report) >= {"input", "recovered", "relative_error", "worst"}
    assert report["input"]["tensile_warp"] == 21300.0
    assert report["worst"] < 0.05


def test_cantilever_on_a_material_file(root):
    report = flexsurf.cantilever(root / "materials" / "denim.toml", direction="weft")
    assert report["direction"] == "weft"
    assert 30.0 < report["chord_angle_deg"] < 50.0


def test_cusick_with_keyword_material():
    soft = flexsurf.Material(preset="paper-cotton", bending_warp=5e-6, bending_weft=5e-6)
    report = flexsurf.cusick(soft, specimen=0.30, level=0)
    assert 0.0 < report["drape_coefficient"] < 100.0 and report["nodes"] >= 3


def test_bad_test_arguments_raise():
    with pytest.raises(ValueError, match="direction"):
        flexsurf.cantilever(direction="sideways")
    with pytest.raises(ValueError, match="specimen"):
        flexsurf.cusick(specimen=0.1)
    with pytest.raises(ValueError, match="calibration"):
        flexsurf.kes(calibration="magic")
    # A bad width is a bad argument (ValueError, as a bad overhang is), not a failed simulation.
    with pytest.raises(ValueError, match="width: NaN m must be a positive length"):
        flexsurf.cantilever(width=float("nan"))
    # A strip kilometres long ran 300 static iterations before failing; the command line refused it already.
    with pytest.raises(ValueError, match=r"overhang: 1000000 m must be a positive length of at most 10 m"):
        flexsurf.cantilever(overhang=1e6)
    with pytest.raises(ValueError, match=r"width: 20 m must be a positive length of at most 10 m"):
        flexsurf.cantilever(width=20.0)
    with pytest.raises(TypeError):
        flexsurf.kes(material=3.5)
    # A huge specimen's default grid is refused by its memory estimate (it aborted the interpreter on an
    # allocation of hundreds of petabytes).
    with pytest.raises(flexsurf.SimulationError, match="memory"):
        flexsurf.cusick(specimen=1e9)


def test_fit_from_a_dict(root):
    problem = {
        "material": str(root / "materials" / "woven-medium.toml"),
        "units": "kes",
        "columns": 18,
        "free": {"bending_warp": {}, "density": {}},
        "target": [
            {"quantity": "bending_length.warp", "value": 1.6, "sigma": 0.02},
            {"quantity": "kes.weight", "value": 25.3, "sigma": 0.3},
        ],
    }
    out = flexsurf.fit(problem)
    report = out["report"]
    assert report["converged"] and report["not_identifiable"] == []
    names = [c["name"] for c in report["constants"]]
    assert names == ["bending_warp", "density"]
    assert abs(report["residuals"][0]["normalised"]) < 1e-6
    with pytest.raises(flexsurf.SceneError) as e:
        flexsurf.fit({**problem, "free": {"poisson": {}}})
    assert e.value.key == "free.poisson"
