"""``flexsurf.run`` against ``flexsurf run``: the same files, bit for bit; the frames as arrays."""

from __future__ import annotations

import json
import subprocess
import warnings

import numpy as np
import pytest

import flexsurf

# Wall-clock measurements (and the provenance: the command line) differ from run to run; everything else in
# summary.json must agree exactly.
TIMED = ("wall_seconds", "steps_per_second", "timings", "provenance")


def files_of(out):
    return sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())


def test_run_writes_the_cli_files_bit_for_bit(tmp_path, cli, small_drop_file):
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    subprocess.run([str(cli), "run", str(small_drop_file), "--out", str(cli_out)], check=True, capture_output=True)
    result = flexsurf.run(small_drop_file, out=py_out)
    assert files_of(cli_out) == files_of(py_out)
    for rel in files_of(cli_out):
        a, b = (cli_out / rel).read_bytes(), (py_out / rel).read_bytes()
        if rel.name == "summary.json":
            ja, jb = json.loads(a), json.loads(b)
            for k in TIMED:
                ja.pop(k), jb.pop(k)
            assert ja == jb
        else:
            assert a == b, f"{rel} differs"
    summary = json.loads((py_out / "summary.json").read_text())
    assert result.summary == summary
    assert list(result.steps) == [0, 20, 40]
    assert result.frames.shape == (3, 11, 11, 3)


def test_run_frames_equal_the_simulation_and_the_obj(small_drop):
    result = flexsurf.run(small_drop)
    assert result.out is None
    sim = flexsurf.Simulation(flexsurf.Scene.from_dict(small_drop))
    assert np.array_equal(result.frames[0], sim.positions)
    sim.step(20)
    assert np.array_equal(result.frames[1], sim.positions)
    sim.step(20)
    assert np.array_equal(result.frames[2], sim.positions)
    assert result.summary["final"]["min_z"] == sim.positions[..., 2].min()


def test_failed_runs_raise(small_drop, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    try:
        flexsurf.run(small_drop, out=blocker)
    except flexsurf.SimulationError as e:
        assert "cannot write" in str(e)
    else:
        raise AssertionError("running into a file should fail")


def test_a_contact_too_soft_to_hold_the_cloth_warns(small_drop):
    # The ball drop's sheet sinks into the ball deeper than the contact offset under a penalty 30 times too
    # soft: summary.json's warning, issued as a RuntimeWarning; the scene's own stiffness warns of nothing.
    soft = flexsurf.with_overrides(small_drop, {"contact.stiffness": 300.0, "time.steps": 60})
    with pytest.warns(RuntimeWarning, match="below an obstacle's surface"):
        result = flexsurf.run(soft)
    assert len(result.summary["warnings"]) == 1
    assert result.summary["max_penetration_seen"] > small_drop["contact"]["offset"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        held = flexsurf.run(flexsurf.with_overrides(small_drop, {"time.steps": 60}))
    assert "warnings" not in held.summary
