"""Regenerate the README's figures from the demo voyage: ``python docs/make_figures.py``.

Runs :func:`optroute.demo.run_demo` (the same computation as ``optroute demo``:
San Diego → Tokyo through ``north_pacific_storms()``, searched and optimised)
in a temporary folder and copies its PNG figures to ``docs/figures/``, each
written atomically.  Nothing is drawn by hand; run it again after a change to
the physics, the search, the optimiser or the figures, and commit the PNGs.

Options: ``--out DIR`` (default ``docs/figures`` next to this script),
``--cell-nm`` (search grid cell [nm], default 40 as in ``optroute demo``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from optroute.demo import run_demo
from optroute.outputs import write_bytes

HERE = Path(__file__).resolve().parent
MAX_BYTES = 300_000  # keep the repository light: every figure below 300 kB


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
    if too_big:
        print(f"larger than {MAX_BYTES // 1000} kB: {', '.join(too_big)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
