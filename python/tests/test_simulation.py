"""``Simulation``: stepping, arrays, scripted pins and springs, energies and timings; bad arguments raise; the
GIL is released while stepping."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest

import flexsurf


@pytest.fixture
def pinned_drop(small_drop):
    d = flexsurf.with_overrides(small_drop, {"pin": [{"nodes": [[0, 0]]}], "spring": [{"nodes": [[10, 10]], "stiffness": 0.05}]})
    return flexsurf.Scene.from_dict(d)


def test_arrays_have_the_grid_shape(small_drop):
    sim = flexsurf.Simulation(flexsurf.Scene.from_dict(small_drop))
    x = sim.positions
    assert x.shape == (11, 11, 3) and x.dtype == np.float64
    assert np.allclose(x[..., 2], 0.35)
    assert x[0, 0, 0] < x[10, 0, 0] and x[0, 0, 1] < x[0, 10, 1]  # (i, j): i along u1 (x), j along u2 (y)
    assert np.all(sim.velocities == 0.0)
    assert sim.step(5) == 5 and sim.step_count == 5 and math.isclose(sim.time, 0.05)
    v = sim.velocities
    assert v.shape == (11, 11, 3) and np.all(v[..., 2] < 0)
    out = np.empty((11, 11, 3))
    sim.positions_into(out)
    assert np.array_equal(out, sim.positions)


def test_energies_contacts_and_timings(small_drop):
    sim = flexsurf.Simulation(flexsurf.Scene.from_dict(small_drop))
    e0 = sim.energies()
    assert set(e0) == {"step", "time", "kinetic", "membrane", "bending", "potential", "contact"}
    sim.step(40)
    e = sim.energies()
    assert e["kinetic"] > 0 and e["potential"] < e0["potential"]
    assert sim.contacts > 0 and sim.max_penetration >= 0
    t = sim.timings()
    assert all(len(v) == 40 for v in t.values())
    assert np.all(t["wall"] > 0) and np.all(t["wall"] >= t["assembly"]) and t["contacts"][-1] == sim.contacts


def test_moving_a_pin_drags_the_corner(pinned_drop):
    sim = flexsurf.Simulation(pinned_drop)
    assert sim.pinned == [(0, 0)]
    start = sim.positions[0, 0].copy()
    for k in range(1, 11):
        sim.move_pin(0, 0, start + [0.0, 0.0, 0.01 * k])
        sim.step()
    assert np.array_equal(sim.positions[0, 0], start + [0.0, 0.0, 0.1])


def test_moving_a_spring_target(pinned_drop):
    sim = flexsurf.Simulation(pinned_drop)
    assert sim.spring_nodes == [(10, 10)]
    target = sim.spring_targets[0]
    assert np.array_equal(target, sim.positions[10, 10])
    sim.set_spring_target(0, target + [0.0, 0.0, 0.1])
    assert np.array_equal(sim.spring_targets[0], target + [0.0, 0.0, 0.1])
    free = flexsurf.Simulation(pinned_drop)
    sim.step(10)
    free.step(10)
    assert sim.positions[10, 10, 2] > free.positions[10, 10, 2]


def test_bad_arguments_raise_and_do_not_crash(pinned_drop):
    sim = flexsurf.Simulation(pinned_drop)
    with pytest.raises(ValueError, match="shape"):
        sim.positions_into(np.empty((10, 11, 3)))
    with pytest.raises(ValueError, match="contiguous"):
        sim.positions_into(np.empty((11, 11, 6))[..., ::2])
    with pytest.raises(ValueError, match="contiguous"):
        sim.positions_into(np.asfortranarray(np.empty((11, 11, 3))))
    frozen = np.empty((11, 11, 3))
    frozen.flags.writeable = False
    with pytest.raises(ValueError):
        sim.positions_into(frozen)
    with pytest.raises(TypeError):
        sim.positions_into(np.empty((11, 11, 3), dtype=np.float32))
    with pytest.raises(ValueError, match="not finite"):
        sim.move_pin(0, 0, [0.0, math.nan, 0.0])
    with pytest.raises(ValueError, match="not pinned"):
        sim.move_pin(5, 5, [0.0, 0.0, 0.0])
    with pytest.raises(IndexError):
        sim.move_pin(11, 0, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="3 numbers"):
        sim.move_pin(0, 0, [0.0, 0.0])
    with pytest.raises(TypeError):
        sim.move_pin(0, 0, "abc")
    with pytest.raises(ValueError, match="does not exist"):
        sim.set_spring_target(3, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="not finite"):
        sim.set_spring_target(0, np.array([np.inf, 0.0, 0.0]))
    with pytest.raises(OverflowError):
        sim.step(-1)
    with pytest.raises(TypeError):
        flexsurf.Simulation("scene.toml")
    assert sim.step(2) == 2  # still usable


@pytest.mark.parametrize("far", [1e300, -2e6])
def test_regression_a_pin_moved_to_1e300_left_the_energies_nan(pinned_drop, far):
    # move_pin(…, [1e300, 0, 0]) was accepted: the energies then read membrane = nan, and the next step failed
    # as a factorisation. Scripted positions obey the scene's ±1e6 m coordinate bound.
    sim = flexsurf.Simulation(pinned_drop)
    sim.step(2)
    with pytest.raises(ValueError, match=r"position: .* outside the accepted range ±1e6 m"):
        sim.move_pin(0, 0, [far, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"target: .* outside the accepted range ±1e6 m"):
        sim.set_spring_target(0, [0.0, 0.0, far])
    assert all(math.isfinite(v) for v in sim.energies().values())
    sim.move_pin(0, 0, [-1e6, 0.0, 0.0])  # the bound itself is a position
    sim.set_spring_target(0, [0.0, 1e6, 0.0])

def test_divergence_raises_simulation_error(small_drop):
    d = flexsurf.with_overrides(small_drop, {"integrator.kind": "lagged", "time.dt": 0.01})
    # Fifty times the lagged scheme's stability limit, which the scene says (test_trust.py).
    with pytest.warns(flexsurf.FlexsurfWarning, match="stability limit"):
        sim = flexsurf.Simulation(flexsurf.Scene.from_dict(d))
    with pytest.raises(flexsurf.SimulationError, match="diverged"):
        sim.step(200)
    assert np.all(np.isfinite(sim.positions))


def test_static_scenes_are_run_not_stepped(small_drop):
    d = flexsurf.with_overrides(small_drop, {"integrator.kind": "static", "pin": [{"set": "corners"}]})
    with pytest.raises(ValueError, match="static"):
        flexsurf.Simulation(flexsurf.Scene.from_dict(d))


def test_the_gil_is_released_while_stepping(small_drop):
    d = flexsurf.with_overrides(small_drop, {"sheet.nodes": [61, 61]})
    sim = flexsurf.Simulation(flexsurf.Scene.from_dict(d))
    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    # Size the call from one timed step so that it lasts about half a second on any machine
    # (a fixed count took 0.198 s on a fast CI machine, too short to tell).
    s0 = time.perf_counter()
    sim.step(1)
    per_step = max(time.perf_counter() - s0, 1e-4)
    n = min(max(8, math.ceil(0.5 / per_step)), 2000)
    thread = threading.Thread(target=ticker)
    thread.start()
    time.sleep(0.05)
    t0 = time.perf_counter()
    sim.step(n)
    t1 = time.perf_counter()
    stop.set()
    thread.join()
    during = [t for t in ticks if t0 < t < t1]
    assert t1 - t0 > 0.2, f"the step should be long enough to tell ({n} steps took {t1 - t0:.3f} s)"
    # With the GIL held the other thread would not tick at all during the call.
    assert len(during) >= 10, f"{len(during)} ticks in {t1 - t0:.2f} s"
    assert sim.step_count == 1 + n


def test_regression_a_scene_of_several_sheets_could_not_be_run_from_python(root):
    # Every scene of several sheets (two sheets, a pile, each sewn garment) raised "the Python bindings give
    # (M, N, 3) arrays of a scene of one sheet (run it with flexsurf.run ...)", and flexsurf.run raised the same:
    # none could be stepped, run or swept from Python. Their arrays are (n, 3) over the model's nodes.
    d = flexsurf.scene_dict(root / "scenes" / "two_sheets.toml")
    d["sheet"][0]["nodes"], d["sheet"][1]["nodes"] = [7, 7], [5, 5]
    d["time"].update(steps=6, output_every=3)
    d["pin"] = [{"sheet": 1, "nodes": [[0, 0]]}]
    d["output"]["image_size"] = [96, 72]
    scene = flexsurf.Scene.from_dict(d, file=root / "scenes" / "two_sheets.toml")
    assert scene.shape == (74, 3)
    with pytest.raises(ValueError, match="not one grid"):
        scene.grid
    sim = flexsurf.Simulation(scene)
    assert sim.positions.shape == sim.velocities.shape == (74, 3)
    assert sim.pinned == [49]  # the second sheet's first node, after the first sheet's 49
    start = sim.positions[49].copy()
    with pytest.raises(ValueError, match="not one grid"):
        sim.move_pin(0, 0, start)
    with pytest.raises(IndexError, match="outside the model's 74 nodes"):
        sim.move_pin(74, start)
    sim.move_pin(49, start + [0.0, 0.0, 0.01])
    sim.step()
    assert np.array_equal(sim.positions[49], start + [0.0, 0.0, 0.01])
    sim.move_pin(49, start)
    sim.step(5)
    buf = np.empty((74, 3))
    sim.positions_into(buf)
    with pytest.raises(ValueError, match=r"must be \(74, 3\)"):
        sim.positions_into(np.empty((73, 3)))
    r = flexsurf.run(flexsurf.Scene.from_dict(d, file=root / "scenes" / "two_sheets.toml"))
    assert r.frames.shape == (3, 74, 3) and list(r.steps) == [0, 3, 6]
    assert np.array_equal(r.frames[0][:49], flexsurf.Simulation(scene).positions[:49])
    assert np.isfinite(buf).all() and "nodes=74" in repr(sim)
    # Each sheet's nodes in that numbering: its (M, N, 3) grid is positions[nodes].
    first, second = scene.panels
    assert first["shape"] == (7, 7) and second["shape"] == (5, 5) and second["nodes"][0, 0] == 49
    assert np.array_equal(np.sort(np.concatenate([first["nodes"].ravel(), second["nodes"].ravel()])), np.arange(74))
    assert sim.positions[second["nodes"]].shape == (5, 5, 3)


def test_a_garment_s_panels_name_their_nodes(root):
    scene = flexsurf.Scene.from_toml(root / "scenes" / "four_gore_skirt.toml")
    panels = scene.panels
    assert [p["name"] for p in panels] == ["front", "right", "back", "left"]
    nodes = np.concatenate([p["nodes"].ravel() for p in panels])
    # The seams join nodes of two panels: every node appears, some in two panels.
    assert set(nodes.tolist()) == set(range(scene.shape[0])) and len(nodes) > scene.shape[0]


def test_regression_a_bool_stood_in_for_a_step_count_or_a_coordinate(pinned_drop):
    sim = flexsurf.Simulation(pinned_drop)
    with pytest.raises(TypeError, match=r"argument 'n'.*got the bool True"):
        sim.step(True)
    with pytest.raises(TypeError, match=r"argument 'first'.*got the bool"):
        sim.move_pin(False, 0, [0.0, 0.0, 0.0])
    with pytest.raises(TypeError, match=r"position: expected a sequence of 3 numbers"):
        sim.move_pin(0, 0, [True, 0.0, 0.0])
    with pytest.raises(TypeError, match=r"argument 'index'.*got the bool"):
        sim.set_spring_target(False, [0.0, 0.0, 0.0])
    assert sim.step_count == 0
    assert sim.step(np.int64(1)) == 1  # numpy integers stay counts
