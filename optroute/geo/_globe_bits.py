"""The GLOBE land mask bit-packed in latitude bands, read band by band on first use.

``global-land-mask`` ships the GLOBE 30-arc-second mask (GLOBE Task Team, 1999; Karin, 2020) as one
deflated 933 MB boolean array: any look-up must inflate all of it, 3–8 CPU-s per process (every
CLI call, every test worker and every Dask worker paid it).  This module stores the same cells
bit-packed (1 = land) in bands of :data:`BAND_ROWS` rows, each deflated on its own inside one
``.npz`` (``globe_land_bits.npz``, 1.6 MB, shipped with optroute), so a look-up inflates only the
bands its latitudes fall in (a few milliseconds each).

The packaged file records the SHA-256 of the ``globe_combined_mask_compressed.npz`` it was built
from; :class:`optroute.geo.land.GlobeLandMask` uses it only when the installed file has that digest
and streams the installed file otherwise, so the answers are always those of
``global_land_mask.globe.is_land``.  ``tests/test_land.py`` rebuilds the bands from the source and
checks them bit for bit.  Regenerate after a ``global-land-mask`` data change with
``python -m optroute.geo._globe_bits``.
"""

from __future__ import annotations

import hashlib
import os
import threading
import uuid
import zipfile
from pathlib import Path

import numpy as np

from optroute.errors import ConfigError

BAND_ROWS = 120
"""Rows (1/120° each, so 1° of latitude) per separately deflated band."""

PACKED_PATH = Path(__file__).with_name("globe_land_bits.npz")
"""The packaged bands (next to this module)."""

SOURCE_NAME = "globe_combined_mask_compressed.npz"
"""The file of ``global-land-mask`` the bands are built from."""


def sha256_of(path: str | Path) -> str:
    """Hex SHA-256 digest of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as fp:
        for chunk in iter(lambda: fp.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def read_axes(source: str | Path) -> np.ndarray:
    """``[lat0, lat_last, lat_min, lat_max, lon0, lon_last, lon_min, lon_max, n_lat, n_lon]`` of the source [deg]."""
    with np.load(source) as f:
        lat = np.asarray(f["lat"], dtype=float)
        lon = np.asarray(f["lon"], dtype=float)
    return np.array(
        [lat[0], lat[-1], lat.min(), lat.max(), lon[0], lon[-1], lon.min(), lon.max(), lat.size, lon.size], dtype=float
    )


def stream_packed(source: str | Path, shape: tuple[int, int]) -> np.ndarray:
    """The source's mask bit-packed along longitude (1 = land), inflated 720 rows at a time.

    Parameters
    ----------
    source : path-like
        ``globe_combined_mask_compressed.npz`` (``mask`` True on the ocean, C order).
    shape : (int, int)
        The expected (n_lat, n_lon) of ``mask``.

    Returns
    -------
    ndarray of uint8, shape (n_lat, ceil(n_lon / 8))
    """
    from numpy.lib import format as npy_format

    with zipfile.ZipFile(source) as zf, zf.open("mask.npy") as fp:
        version = npy_format.read_magic(fp)
        if version == (1, 0):
            found, fortran, dtype = npy_format.read_array_header_1_0(fp)
        else:
            found, fortran, dtype = npy_format.read_array_header_2_0(fp)
        if fortran or dtype != np.dtype(bool) or tuple(found) != tuple(shape):
            raise ConfigError(
                f"{source} does not hold the expected C-ordered boolean {shape[0]}x{shape[1]} mask "
                f"(found {dtype}, shape {found}); reinstall global-land-mask"
            )
        ny, nx = shape
        packed = np.empty((ny, (nx + 7) // 8), dtype=np.uint8)
        for i in range(0, ny, 720):
            k = min(720, ny - i)
            block = np.frombuffer(fp.read(k * nx), dtype=np.uint8).reshape(k, nx)
            packed[i : i + k] = np.packbits(block == 0, axis=1)  # 1 = land
    return packed


def write_packed(source: str | Path, out: str | Path = PACKED_PATH) -> Path:
    """Build the banded file from ``source`` and write it atomically (temporary name, then rename).

    Returns
    -------
    Path
        ``out``.
    """
    source, out = Path(source), Path(out)
    axes = read_axes(source)
    packed = stream_packed(source, (int(axes[8]), int(axes[9])))
    bands = {f"band{k:04d}": packed[i : i + BAND_ROWS] for k, i in enumerate(range(0, packed.shape[0], BAND_ROWS))}
    tmp = out.with_name(f".tmp-{uuid.uuid4().hex}-{out.name}")
    try:
        with open(tmp, "wb") as fp:
            np.savez_compressed(
                fp,
                source_sha256=np.array(sha256_of(source)),
                axes=axes,
                band_rows=np.array(BAND_ROWS),
                **bands,
            )
            fp.flush()
            os.fsync(fp.fileno())
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out


class BandedBits:
    """The bit-packed mask, its bands inflated from the packaged file when first needed.

    ``bits`` has the full shape from the start (zero pages the system does not commit until
    written); :meth:`ensure_rows` inflates the bands that cover a range of rows.  Thread-safe.
    """

    def __init__(self, path: str | Path = PACKED_PATH) -> None:
        self.path = Path(path)
        with np.load(self.path) as f:
            self.source_sha256 = str(f["source_sha256"])
            self.axes = np.asarray(f["axes"], dtype=float)
            self.band_rows = int(f["band_rows"])
        ny, nx = int(self.axes[8]), int(self.axes[9])
        self.bits = np.zeros((ny, (nx + 7) // 8), dtype=np.uint8)
        self._loaded = np.zeros(-(-ny // self.band_rows), dtype=bool)
        self._lock = threading.Lock()

    def ensure_rows(self, rows: np.ndarray) -> None:
        """Inflate every band holding one of ``rows`` (row indices, any shape) that is not loaded yet."""
        rows = np.asarray(rows, dtype=np.int64)
        if rows.size == 0:
            return
        lo, hi = int(rows.min()) // self.band_rows, int(rows.max()) // self.band_rows
        if self._loaded[lo : hi + 1].all():
            return
        needed = np.bincount(rows.ravel() // self.band_rows, minlength=self._loaded.size) > 0
        missing = np.flatnonzero(needed & ~self._loaded)
        with self._lock, np.load(self.path) as f:
            for k in missing:
                if not self._loaded[k]:
                    i = int(k) * self.band_rows
                    self.bits[i : i + self.band_rows] = f[f"band{int(k):04d}"]
                    self._loaded[k] = True


if __name__ == "__main__":
    import importlib.util

    spec = importlib.util.find_spec("global_land_mask")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("pip install global-land-mask first: the bands are built from its data file")
    src = Path(next(iter(spec.submodule_search_locations))) / SOURCE_NAME
    print(f"wrote {write_packed(src)} from {src}")
