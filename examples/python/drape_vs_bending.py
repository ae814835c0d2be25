"""Drape coefficient vs bending rigidity: a Cusick sweep over the warp and weft bending rigidity of the paper's
non-woven cotton, on a local process pool (or Ray: ``--backend ray``), with a plot.

    python examples/python/drape_vs_bending.py [--backend process|ray] [--out out/python]

Writes ``drape_vs_bending.parquet`` (when pyarrow is installed) and ``drape_vs_bending.png`` (when matplotlib
is installed; otherwise says so and skips the plot).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import flexsurf


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="process", choices=["process", "ray"])
    parser.add_argument("--out", default="out/python", type=Path)
    parser.add_argument("--points", default=6, type=int, help="bending rigidities on a log scale")
    parser.add_argument("--level", default=0, type=int, help="Cusick grid level (0 coarse, 1 default)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    rigidities = np.geomspace(1e-6, 2e-4, args.points)  # N·m
    cases = [
        {"material.bending_warp": float(k), "material.bending_weft": float(k), "specimen": 0.30, "level": args.level}
        for k in rigidities
    ]
    try:
        import pyarrow  # noqa: F401

        parquet = args.out / "drape_vs_bending.parquet"
    except ImportError:
        parquet = None
    table = flexsurf.sweep("cusick", cases, backend=args.backend, parquet=parquet)
    print(table[["material.bending_warp", "drape_coefficient", "nodes", "error"]].to_string(index=False))
    if parquet is not None:
        print(f"wrote {parquet}")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: skipping the plot (pip install matplotlib)")
        return
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.semilogx(table["material.bending_warp"], table["drape_coefficient"], "o-")
    ax.set_xlabel("bending rigidity K1 = K2 (N·m)")
    ax.set_ylabel("drape coefficient (%)")
    ax.set_title("Cusick drape, 30 cm specimen")
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    png = args.out / "drape_vs_bending.png"
    fig.savefig(png, dpi=120)
    print(f"wrote {png}")


if __name__ == "__main__":
    main()
