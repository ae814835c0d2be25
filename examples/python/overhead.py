"""The cost of calling flexsurf from Python: the 300-step ball drop (scenes/ball_drop.toml) run by the command
line and by ``flexsurf.run`` (same files), and stepped by ``Simulation`` reading the positions every step,
alternately, several times; prints the median wall times and the overhead.

    python examples/python/overhead.py [--cli target/release/flexsurf] [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import flexsurf

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cli", default=ROOT / "target" / "release" / "flexsurf", type=Path)
    parser.add_argument("--repeat", default=5, type=int)
    args = parser.parse_args()
    scene_path = ROOT / "scenes" / "ball_drop.toml"
    times: dict[str, list[float]] = {"cli run": [], "flexsurf.run": [], "Simulation.step + positions": []}
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            subprocess.run([str(args.cli), "run", str(scene_path), "--out", f"{tmp}/cli"], check=True, capture_output=True)
            times["cli run"].append(time.perf_counter() - t)
            t = time.perf_counter()
            flexsurf.run(scene_path, out=f"{tmp}/py")
            times["flexsurf.run"].append(time.perf_counter() - t)
        t = time.perf_counter()
        sim = flexsurf.Simulation(flexsurf.Scene.from_toml(scene_path))
        x = np.empty((*sim.grid, 3))
        for _ in range(300):
            sim.step()
            sim.positions_into(x)
        times["Simulation.step + positions"].append(time.perf_counter() - t)
    base = statistics.median(times["cli run"])
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"{name:30s} median {med:.3f} s  ({100 * (med / base - 1):+.1f} % vs the CLI; runs {', '.join(f'{v:.3f}' for v in ts)})")


if __name__ == "__main__":
    main()
