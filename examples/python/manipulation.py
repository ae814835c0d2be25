"""Scripted manipulation: the ball drop with one corner pinned, the corner carried along a path (up, across
and down, like a gripper) while the sheet drapes on the ball.

    python examples/python/manipulation.py [--out out/python]

Prints the corner's and the sheet's heights along the way and writes ``manipulation.npz`` (the positions of
every tenth step, shape (F, M, N, 3)).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import flexsurf

ROOT = Path(__file__).resolve().parents[2]


def corner_path(start: np.ndarray, steps: int) -> np.ndarray:
    """The gripper's path: lift 20 cm, carry 40 cm across the ball towards +x, lower 10 cm; one point per step."""
    lift = start + [0.0, 0.0, 0.2]
    across = lift + [0.4, 0.0, 0.0]
    down = across + [0.0, 0.0, -0.1]
    legs = [(start, lift), (lift, across), (across, down)]
    per_leg = steps // len(legs)
    points = [a + (b - a) * s for a, b in legs for s in np.linspace(0.0, 1.0, per_leg, endpoint=False)[1:]]
    points += [down] * (steps - len(points))
    return np.array(points)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/python", type=Path)
    parser.add_argument("--steps", default=300, type=int)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    d = flexsurf.scene_dict(ROOT / "scenes" / "ball_drop.toml")
    d["pin"] = [{"nodes": [[0, 0]]}]
    d["time"]["steps"] = args.steps
    sim = flexsurf.Simulation(flexsurf.Scene.from_dict(d, ROOT / "scenes" / "ball_drop.toml"))
    m, n = sim.grid
    path = corner_path(sim.positions[0, 0].copy(), args.steps)

    frames = []
    x = np.empty((m, n, 3))
    for k, point in enumerate(path, start=1):
        sim.move_pin(0, 0, point)
        sim.step()
        if k % 10 == 0 or k == args.steps:
            sim.positions_into(x)
            frames.append(x.copy())
        if k % 50 == 0 or k == args.steps:
            e = sim.energies()
            print(
                f"step {k:4d}: corner at ({x[0, 0, 0]:+.3f}, {x[0, 0, 1]:+.3f}, {x[0, 0, 2]:+.3f}) m, "
                f"centre z {x[m // 2, n // 2, 2]:.3f} m, lowest z {x[..., 2].min():+.3f} m, "
                f"contacts {sim.contacts}, bending {e['bending']:.2e} J"
            )
    np.savez_compressed(args.out / "manipulation.npz", frames=np.array(frames))
    t = sim.timings()
    print(f"{args.steps} steps, {t['wall'].mean() * 1e3:.2f} ms per step; wrote {args.out / 'manipulation.npz'}")


if __name__ == "__main__":
    main()
