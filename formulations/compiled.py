"""CasADi functions compiled to C once per machine: a disk cache of shared libraries keyed by their generated code.

CasADi's own ``jit`` option (the ``"shell"`` plugin) compiles a function every time it is built, in a temporary
folder removed when the function is unloaded, so every process and every corridor pays the C compiler again. Here
the C source of a function (:class:`casadi.CodeGenerator`) is hashed together with the compiler, its flags and the
CasADi version; the shared library is built once under that hash in a cache folder and loaded with
:func:`casadi.external` from then on, by any process. A function whose code is already cached costs one
``dlopen``. A library not loaded for :data:`STALE_DAYS` days is removed when another is built.

The flags keep the arithmetic as CasADi's virtual machine does it: ``-O1`` (no ``-ffast-math``) and
``-ffp-contract=off`` (no fused multiply-add), so that a compiled function gives the same numbers as the
interpreted one. ``tests/test_compiled.py`` checks that bit for bit on each machine the suite runs on: the C
library's ``sin`` or ``pow`` could still differ in the last bit from the one CasADi was built with.

Where no compiler runs, or the cache folder cannot be written, :func:`compiled_function` returns the function as it
was (interpreted) and says why: compilation is a speed-up, never a condition.
"""

from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["CACHE_ENV", "COMPILE_FLAGS", "STALE_DAYS", "cache_dir", "compiled_function", "compiler"]

#: The environment variable naming the cache folder (default: ``$XDG_CACHE_HOME/optroute/casadi``, else
#: ``~/.cache/optroute/casadi``; ``<temp dir>/optroute-casadi-<uid>`` where neither can be written).
CACHE_ENV = "OPTROUTE_CASADI_CACHE"
#: The C compiler's flags: the virtual machine's arithmetic (no fast-math, no contraction into fused multiply-adds),
#: optimised at ``-O1``: on the 300-leg storm corridor of ``benchmarks/_nlp_call.py`` the leg functions compiled in
#: 5.4 CPU-s at ``-O1``, 1.4 at ``-O0`` and 9.2 at ``-O2``, and the Hessian's 60 calls took 0.09, 0.22 and 0.09 s
#: (0.75 s interpreted).
COMPILE_FLAGS = ("-O1", "-ffp-contract=off", "-fPIC", "-shared")
#: Longest a compilation may take [s] before the function is kept interpreted.
COMPILE_TIMEOUT_S = 600.0
#: A cached library not loaded for this long [days] is removed when another is built: one is kept per ship, band
#: set and sample layout (a few hundred kB each), so a cache that only grew would fill the disk over the studies of
#: many ships. Loading it marks it used (its modification time); a process that has it loaded keeps its copy.
STALE_DAYS = 60.0


def compiler() -> list[str]:
    """The C compiler's command: ``$CC`` split as a shell would (e.g. ``"ccache gcc"``), else ``gcc``."""
    return shlex.split(os.environ.get("CC", "")) or ["gcc"]


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".probe-"):
            pass
    except OSError:
        return False
    return True


def cache_dir() -> Path | None:
    """The cache folder of compiled libraries (created), or None where no candidate can be written."""
    given = os.environ.get(CACHE_ENV)
    if given:
        return Path(given) if _writable(Path(given)) else None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    uid = getattr(os, "getuid", lambda: "user")()
    for folder in (Path(base) / "optroute" / "casadi", Path(tempfile.gettempdir()) / f"optroute-casadi-{uid}"):
        if _writable(folder):
            return folder
    return None


def _source(fun: Any) -> str:
    import casadi as ca

    gen = ca.CodeGenerator(f"{fun.name()}.c", {"with_header": False})
    gen.add(fun)
    return gen.dump()


def _build(source: str, library: Path, command: list[str]) -> str | None:
    """Compile ``source`` into ``library`` (written under a temporary name, then renamed: another process never
    loads a half-written library); None, or why it could not be."""
    stem = f".{library.stem}-{os.getpid()}-{os.urandom(4).hex()}"
    c_file, partial = library.with_name(stem + ".c"), library.with_name(stem + ".so")
    try:
        c_file.write_text(source)
        done = subprocess.run(
            [*command, *COMPILE_FLAGS, str(c_file), "-o", str(partial), "-lm"],
            capture_output=True, text=True, timeout=COMPILE_TIMEOUT_S, check=False,
        )  # fmt: skip
        if done.returncode != 0:
            return f"{command[0]} exited with {done.returncode}: {done.stderr.strip()[:300]}"
        os.replace(partial, library)
        return None
    except (OSError, subprocess.SubprocessError) as exc:
        return f"{command[0]} could not compile it: {exc}"
    finally:
        for leftover in (c_file, partial):
            leftover.unlink(missing_ok=True)


def _touch(library: Path) -> None:
    """Mark a cached library used now (its modification time), so that :func:`_prune` keeps it."""
    try:
        os.utime(library)
    except OSError:  # a read-only cache still serves its libraries
        pass


def _prune(folder: Path, keep: Path) -> None:
    """Remove the cache's libraries not used for :data:`STALE_DAYS` days, ``keep`` aside."""
    oldest = time.time() - STALE_DAYS * 86400.0
    for library in folder.glob("*.so"):
        try:
            if library != keep and library.stat().st_mtime < oldest:
                library.unlink()
        except OSError:  # removed by another process meanwhile, or not ours to remove
            pass


def compiled_function(fun: Any) -> tuple[Any, str]:
    """``fun`` (a CasADi SX function) compiled to C through the disk cache, and how.

    Returns
    -------
    function : casadi.Function
        The compiled function (:func:`casadi.external` of the cached library), or ``fun`` itself where it could
        not be compiled.
    how : str
        ``"cached"`` (the library was there), ``"compiled"`` (built now), or why ``fun`` stays interpreted.
    """
    import casadi as ca

    command = compiler()
    if shutil.which(command[0]) is None:
        return fun, f"no C compiler {command[0]!r} on the PATH (set CC to name one)"
    folder = cache_dir()
    if folder is None:
        return fun, f"no writable cache folder (set {CACHE_ENV} to one)"
    source = _source(fun)
    key = hashlib.sha256("\0".join([source, *command, *COMPILE_FLAGS, ca.__version__]).encode()).hexdigest()[:32]
    library = folder / f"{fun.name()}-{key}.so"
    how = "cached"
    if library.exists():
        _touch(library)
    else:
        why = _build(source, library, command)
        if why is not None:
            return fun, why
        how = "compiled"
        _prune(folder, keep=library)
    try:
        return ca.external(fun.name(), str(library)), how
    except RuntimeError as exc:  # an unreadable library: removed, so that the next build makes it again
        library.unlink(missing_ok=True)
        return fun, f"the cached library could not be loaded: {exc}"
