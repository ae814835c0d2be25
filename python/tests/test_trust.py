"""Issue 22 at the Python boundary: recursive and deep structures, numpy integers, Ctrl-C during a long
``Simulation.step``, runs into an existing folder, and the README's snippet run verbatim as a script."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import flexsurf

ROOT = Path(__file__).resolve().parents[2]


def test_a_dict_that_contains_itself_raises_naming_the_key(small_drop):
    d = dict(small_drop)
    d["extra"] = {}
    d["extra"]["self"] = d["extra"]
    with pytest.raises(ValueError, match=r"`extra\.self\.self.*nested deeper than 64 levels"):
        flexsurf.Scene.from_dict(d)


def test_lists_nested_20000_deep_raise_naming_the_key(small_drop):
    deep: list = []
    for _ in range(20000):
        deep = [deep]
    d = dict(small_drop)
    d["sheet"] = dict(d["sheet"], size=deep)
    with pytest.raises(ValueError, match=r"`sheet\.size\[0\]\[0\].*nested deeper"):
        flexsurf.Scene.from_dict(d)


def test_numpy_integers_are_integers(small_drop):
    d = dict(small_drop)
    d["sheet"] = dict(d["sheet"], nodes=[np.int64(9), np.int32(9)])
    d["time"] = dict(d["time"], steps=np.uint16(20))
    scene = flexsurf.Scene.from_dict(d)
    assert scene.grid == (9, 9) and scene.steps == 20
    # numpy floats stay floats: an integer key refuses 2.0 as it refuses a float from a file.
    d["time"] = dict(d["time"], steps=np.float64(20.0))
    with pytest.raises(flexsurf.SceneError):
        flexsurf.Scene.from_dict(d)


def test_a_sweep_over_a_numpy_integer_array(small_drop):
    table = flexsurf.sweep(small_drop, {"time.steps": np.array([20, 40])}, workers=1)
    assert table["error"].isna().all(), table["error"].tolist()
    assert table["steps"].tolist() == [20, 40]


def test_regression_a_numpy_array_could_not_stand_in_a_scene(small_drop):
    # `gravity = np.array([0, 0, -9.81])` raised "a value of type ndarray cannot stand in a scene", while numpy
    # scalars were accepted; arrays stand in as the lists they hold (integer arrays as integers).
    lists = flexsurf.with_overrides(small_drop, {"gravity": [0.0, 0.0, -5.0], "sheet.nodes": [9, 9]})
    as_lists = flexsurf.Simulation(flexsurf.Scene.from_dict(lists)).energies()["potential"]
    d = flexsurf.with_overrides(small_drop, {"gravity": np.array([0.0, 0.0, -5.0]), "sheet.nodes": np.array([9, 9])})
    d["pin"] = [{"nodes": np.array([[0, 0], [8, 0]])}]
    scene = flexsurf.Scene.from_dict(d)
    assert scene.grid == (9, 9) and flexsurf.Simulation(scene).energies()["potential"] == as_lists
    assert flexsurf.Simulation(scene).pinned == [(0, 0), (8, 0)]
    with pytest.raises(flexsurf.SceneError, match="sheet.nodes"):
        flexsurf.Scene.from_dict(flexsurf.with_overrides(small_drop, {"sheet.nodes": np.array([9.0, 9.0])}))


def test_sigint_during_a_long_step_raises_keyboard_interrupt(small_drop):
    sim = flexsurf.Simulation(flexsurf.Scene.from_dict(small_drop))
    # Python turns SIGINT into KeyboardInterrupt only where it started with SIGINT's default disposition: a
    # test run launched in the background by a non-interactive shell (`cmd &`) inherits SIGINT ignored, and the
    # signal below was lost (the step then ran on, seen on 2026-12-07). What a Ctrl-C does is Python's handler,
    # so the test installs it; and the step is long (about 20 s at 0.5 ms a step) but bounded, so that a lost
    # signal fails the test instead of running past CI's limit.
    steps = 40_000
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            sim.step(steps)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - start < 10
    assert 0 < sim.step_count < steps
    sim.step(1)  # the state is the last step's, and stepping goes on


def test_a_run_into_an_existing_run_folder_raises_folder_error(small_drop, tmp_path):
    out = tmp_path / "out"
    flexsurf.run(small_drop, out=out)
    with pytest.raises(flexsurf.FolderError) as e:
        flexsurf.run(small_drop, out=out)
    message = str(e.value)
    assert "overwrite=True" in message and "--" not in message, message
    assert not isinstance(e.value, flexsurf.SimulationError)
    result = flexsurf.run(small_drop, out=out, overwrite=True)
    assert result.summary["steps"] == 40


def readme_snippet() -> str:
    """The Python block of the README's "Python" section."""
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Python") :]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_readme_snippet_runs_verbatim_as_a_script(tmp_path, small_drop):
    for name in ("scenes", "materials", "bodies"):
        (tmp_path / name).symlink_to(ROOT / name)
    # A run already in the snippet's folder (a small one, so the snippet runs once): it must replace it.
    flexsurf.run(small_drop, out=tmp_path / "out" / "py")
    script = tmp_path / "snippet.py"
    script.write_text(readme_snippet())
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr
    summary = json.loads((tmp_path / "out" / "py" / "summary.json").read_text())
    assert summary["steps"] == 300, "the snippet's run replaced the small one"


def test_a_process_sweep_from_an_unguarded_script_says_why(tmp_path, small_drop):
    script = tmp_path / "unguarded.py"
    script.write_text(
        "import flexsurf\n"
        f"d = flexsurf.scene_dict({str(ROOT / 'scenes' / 'ball_drop.toml')!r})\n"
        "d['sheet']['nodes'] = [5, 5]\nd['time']['steps'] = 2\n"
        "flexsurf.sweep(d, {'contact.friction': [0.0, 0.5]}, workers=2)\n"
    )
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode != 0
    assert 'if __name__ == "__main__":' in done.stderr, done.stderr[-2000:]


@pytest.mark.parametrize(
    "out, what",
    [
        (np.zeros((11, 11, 3), dtype=np.float32), r"got a float32 array of shape \(11, 11, 3\)"),
        (np.zeros((121, 3)), r"got a float64 array of shape \(121, 3\)"),
        ([[0.0] * 3] * 121, r"got a list"),
    ],
)
def test_positions_into_a_wrong_array_says_what_it_got(small_drop, out, what):
    sim = flexsurf.Simulation(flexsurf.Scene.from_dict(small_drop))
    with pytest.raises(TypeError, match=r"out: expected a float64 array of shape \(11, 11, 3\), " + what):
        sim.positions_into(out)
    right = np.zeros((11, 11, 3))
    sim.positions_into(right)
    assert np.array_equal(right, sim.positions)


def test_a_scene_file_that_cannot_be_read_says_why(tmp_path):
    with pytest.raises(flexsurf.SceneError, match=r"missing\.toml: cannot read the file: .*No such file"):
        flexsurf.Scene.from_toml(tmp_path / "missing.toml")
    with pytest.raises(flexsurf.SceneError, match=r"cannot read the file: it is a directory"):
        flexsurf.Scene.from_toml(tmp_path)


@pytest.mark.parametrize(
    "key, error, message",
    [
        ("obstacle.5.sphere.radius", IndexError, r"'obstacle\.5\.sphere\.radius': `obstacle` has 1 entry: index 5"),
        ("obstacle.x.radius", ValueError, r"`obstacle` is a list, indexed by 0, 1, …, not by 'x'"),
        ("obstacle.-1.sphere.radius", ValueError, r"not by '-1'"),
        ("time.dt.x", TypeError, r"'time\.dt\.x': `time\.dt` is 0\.01, not a table or a list"),
        ("time..dt", ValueError, r"'time\.\.dt': a dotted key has no empty parts"),
        ("", ValueError, r"no empty parts"),
    ],
)
def test_an_override_that_cannot_be_set_names_its_key(small_drop, key, error, message):
    with pytest.raises(error, match=message):
        flexsurf.with_overrides(small_drop, {key: 0.2})


def test_an_override_one_past_a_list_adds_an_entry(small_drop):
    floor = {"obstacle.1.plane.point": [0.0, 0.0, -0.5], "obstacle.1.plane.normal": [0.0, 0.0, 1.0]}
    d = flexsurf.with_overrides(small_drop, floor)
    assert d["obstacle"][1] == {"plane": {"point": [0.0, 0.0, -0.5], "normal": [0.0, 0.0, 1.0]}}
    assert len(small_drop["obstacle"]) == 1, "the scene dict given is not changed"
    flexsurf.Scene.from_dict(d)  # a scene with a sphere and a floor


def test_a_run_into_an_empty_path_or_onto_a_file_says_why(small_drop, tmp_path):
    with pytest.raises(flexsurf.FolderError, match=r"the output folder's path is empty: name a folder"):
        flexsurf.run(small_drop, out="")
    (tmp_path / "afile").write_text("mine")
    with pytest.raises(flexsurf.SimulationError, match=r"cannot write .*afile: File exists"):
        flexsurf.run(small_drop, out=tmp_path / "afile")
    assert (tmp_path / "afile").read_text() == "mine"


def test_a_scene_argument_of_the_wrong_type_says_what_it_may_be():
    with pytest.raises(TypeError, match=r"scene: expected a Scene, a path to a TOML scene or a dict of its keys, got int"):
        flexsurf.run(12)
    with pytest.raises(TypeError, match=r"scene: expected a path to a TOML scene, a dict of its keys or one of .*'kes'"):
        flexsurf.sweep(12, [{}])


def test_a_unit_slip_warns_from_python_as_on_the_command_line(small_drop, tmp_path):
    """A scene, material or fit file checked from Python said nothing of a value the command line warns of
    (``density = 70``: g/m² typed into the kg/m² key); each is now a ``FlexsurfWarning`` naming the key."""
    import warnings

    heavy = {**small_drop, "material": {"preset": "paper-cotton", "density": 70}}
    with pytest.warns(flexsurf.FlexsurfWarning, match=r"`material\.density`.*7000 mg/cm²"):
        scene = flexsurf.Scene.from_dict(heavy)
    assert len(scene.warnings) == 1 and "material.density" in scene.warnings[0]
    assert issubclass(flexsurf.FlexsurfWarning, UserWarning)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert flexsurf.Scene.from_dict(small_drop).warnings == []
    with pytest.warns(flexsurf.FlexsurfWarning, match="density"):
        flexsurf.Material(preset="paper-cotton", density=70)
    path = tmp_path / "heavy.toml"
    path.write_text(
        "density = 70\ntensile_warp = 1000\ntensile_weft = 1000\nshear = 10\nbending_warp = 1e-5\nbending_weft = 1e-5\n"
    )
    with pytest.warns(flexsurf.FlexsurfWarning, match="heavy.toml"):
        flexsurf.Material.from_file(path)
    # A fit's material warns too, and its result keeps the warning as data (as `fit.json` does).
    fit_problem = {
        "material": str(path),
        "free": {"shear": {}},
        "target": [{"quantity": "kes.shear", "value": 12.0, "sigma": 0.5}],
    }
    with pytest.warns(flexsurf.FlexsurfWarning, match="heavy.toml"):
        result = flexsurf.fit(fit_problem)
    assert len(result["problem"]["warnings"]) == 1 and "density" in result["problem"]["warnings"][0]
    # The lagged scheme above its stability limit, as `flexsurf check` says.
    lagged = {**small_drop, "integrator": {"kind": "lagged"}}
    with pytest.warns(flexsurf.FlexsurfWarning, match=r"`time\.dt`.*stability limit"):
        flexsurf.Scene.from_dict(lagged)


@pytest.mark.parametrize(
    "call",
    [
        lambda: flexsurf.cantilever(width=True),
        lambda: flexsurf.cantilever(overhang=True),
        lambda: flexsurf.cusick(specimen=True),
        lambda: flexsurf.cusick(level=True),
        lambda: flexsurf.cusick(index=False),
    ],
    ids=["cantilever width", "cantilever overhang", "cusick specimen", "cusick level", "cusick index"],
)
def test_regression_a_bool_stood_in_for_a_number(call):
    # To Python True is the integer 1: cantilever(width=True) ran a 1 m wide strip and cusick(level=True) the
    # default grid, without a word. Number and count arguments refuse bools, naming the argument.
    with pytest.raises(TypeError, match=r"expected a number, got the bool"):
        call()

