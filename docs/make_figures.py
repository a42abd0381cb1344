"""Regenerate the README's figures from the demo voyage: ``python docs/make_figures.py``.

Runs :func:`optroute.cli.demo.run_demo` (the same computation as ``optroute demo``:
San Diego → Tokyo through ``north_pacific_storms()``, searched and optimised)
in a temporary folder and copies its PNG figures to ``docs/figures/``, each
written atomically.  Nothing is drawn by hand; run it again after a change to
the physics, the search, the optimiser or the figures, and commit the PNGs.

The fuel-versus-ETA front comes from :func:`front_png` (the benchmarks' front corridor).

Options: ``--out DIR`` (default ``docs/figures`` next to this script),
``--cell-nm`` (search grid cell [nm], default 40 as in ``optroute demo``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from optroute.cli.demo import run_demo
from optroute.plan.outputs import write_bytes

HERE = Path(__file__).resolve().parent
MAX_BYTES = 300_000  # keep the repository light: every figure below 300 kB


def front_png() -> bytes:
    """The fuel-versus-ETA front of the benchmarks' corridor through a moving storm, as PNG bytes.

    The corridor and weather of ``benchmarks/bench_front.py`` (container_54k_dwt, 2 × ~1 700 nm
    across the equatorial Pacific, a 6 m storm drifting along it), 60 legs, 10 ETAs from the
    minimum-time passage to the slow-steaming limit.
    """
    import io

    import matplotlib.pyplot as plt

    from optroute.studies import tradeoff

    sys.path.insert(0, str(HERE.parent))
    from benchmarks.bench_front import T0, case

    corridor, wx, ship, kw = case(60)
    front = tradeoff(corridor, wx, ship, departure=T0, n=10, **kw)
    fig = front.plot()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    print(front[["fuel_t", "duration_h"]].to_dataframe()[["fuel_t", "duration_h"]].round(2).to_string())
    return buf.getvalue()


def main(argv: list[str] | None = None) -> int:
    """Run the demo and copy its figures; print each figure's path and size [kB]."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "figures", help="folder for the PNGs")
    parser.add_argument("--cell-nm", type=float, default=40.0, help="search grid cell [nm]")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="optroute-figures-") as tmp:
        result = run_demo(tmp, cell_nm=args.cell_nm)
        print(result.table())
        too_big = []
        for src in result.files:
            if src.suffix != ".png":
                continue
            data = src.read_bytes()
            dst = write_bytes(args.out / src.name, data)
            print(f"{dst}  {len(data) / 1000:.0f} kB")
            if len(data) > MAX_BYTES:
                too_big.append(dst.name)
    print(f"demo run {result.runtime_s:.0f} s")
    data = front_png()
    dst = write_bytes(args.out / "front.png", data)
    print(f"{dst}  {len(data) / 1000:.0f} kB")
    if len(data) > MAX_BYTES:
        too_big.append(dst.name)
    if too_big:
        print(f"larger than {MAX_BYTES // 1000} kB: {', '.join(too_big)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
