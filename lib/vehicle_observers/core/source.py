"""The library's own source as a key: one SHA-256 over every ``.py`` file of the installed
packages, and the numba cache folder keyed by it.

Why: numba's on-disk cache (``@njit(cache=True)``) checks only the source file of the
function it compiled. A cached kernel that calls a kernel of another module (the fused
filter calling :mod:`vehicle_observers.baselines.adaptive`'s predict and update) keeps the
callee's old machine code after the callee's file is edited, so results computed on one
machine (with an old cache) and on a clean one (compiling afresh) differ. The same holds for
any on-disk store keyed by a few module files while the computation reaches further.

:func:`package_sha256` covers every module of ``vehicle_observers`` and of the sibling
packages installed from the same folder (``vehicle_observers_papers``): the on-disk caches
(designs, selections, tunings, identifications) and the campaign provenance include it, and
:func:`configure_jit_cache` puts numba's cache in a folder named after it, so any edit of
the library starts from freshly compiled kernels; the folders of other sources unused for 30
days are removed (:func:`prune_jit_caches`). The digest is independent of the machine
(relative paths and file bytes only).
"""

from __future__ import annotations

import hashlib
import os
import re
import sys
from functools import lru_cache
from pathlib import Path

#: name of the numba cache sub-folder for one source digest (``src-`` + 16 hex digits)
_JIT_DIR = re.compile(r"^src-[0-9a-f]{16}$")


def package_files(root: str | os.PathLike | None = None) -> list[Path]:
    """Every ``.py`` file of the packages named ``vehicle_observers*`` in ``root`` (default: the
    folder that holds this package, ``lib/`` of an editable install), sorted by relative
    path; ``__pycache__`` left out."""
    root = Path(__file__).resolve().parents[2] if root is None else Path(root)
    files = []
    for pkg in sorted(root.glob("vehicle_observers*")):
        if pkg.is_dir() and (pkg / "__init__.py").is_file():
            files.extend(f for f in pkg.rglob("*.py") if "__pycache__" not in f.parts)
    return sorted(files, key=lambda f: f.relative_to(root).as_posix())


def tree_sha256(root: str | os.PathLike | None = None) -> str:
    """SHA-256 (hex) of the relative path and bytes of every file of
    :func:`package_files` ``(root)``, each length-prefixed (no two trees share a digest by
    moving bytes between files)."""
    root = Path(__file__).resolve().parents[2] if root is None else Path(root)
    h = hashlib.sha256()
    for f in package_files(root):
        rel = f.relative_to(root).as_posix().encode()
        data = f.read_bytes()
        h.update(len(rel).to_bytes(8, "little") + rel + len(data).to_bytes(8, "little") + data)
    return h.hexdigest()


@lru_cache(maxsize=1)
def package_sha256() -> str:
    """:func:`tree_sha256` of the installed packages, computed once per process (an edit
    during a session is picked up by the next process)."""
    return tree_sha256()


def jit_cache_dir(base: str | os.PathLike | None = None) -> Path:
    """Numba cache folder for this source: ``<base>/src-<16 hex of package_sha256>``;
    ``base`` defaults to ``$NUMBA_CACHE_DIR`` (with a ``src-...`` folder already appended by a
    parent process stripped) or ``<cache_dir>/numba``
    (:func:`vehicle_observers.data.logs.cache_dir` rule, repeated here so that ``core``
    imports nothing of the package)."""
    if base is None:
        base = os.environ.get("NUMBA_CACHE_DIR") or ""
        if base and _JIT_DIR.match(Path(base).name):
            base = str(Path(base).parent)
    if not base:
        d = os.environ.get("VEHICLE_OBSERVERS_CACHE")
        base = (Path(d) if d else
                Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
                / "vehicle_observers") / "numba"
    return Path(base) / f"src-{package_sha256()[:16]}"


#: a numba cache folder of another source not used for this long is removed [s] (30 days)
JIT_KEEP_S = 30 * 86400.0


def prune_jit_caches(current: Path, keep_s: float = JIT_KEEP_S, now: float | None = None) -> list:
    """Remove the ``src-*`` siblings of ``current`` whose modification time is older than
    ``keep_s`` (each process marks its own folder as used, :func:`configure_jit_cache`), so
    the folders of edited sources do not pile up. Errors are ignored (a folder in use by
    another process is at worst compiled again). Returns the removed folders."""
    import shutil
    import time

    now = time.time() if now is None else now
    gone = []
    try:
        for d in current.parent.iterdir():
            if d == current or not d.is_dir() or not _JIT_DIR.match(d.name):
                continue
            if now - d.stat().st_mtime > keep_s:
                shutil.rmtree(d, ignore_errors=True)
                gone.append(d)
    except OSError:
        pass
    return gone


def configure_jit_cache() -> Path | None:
    """Point numba's cache at :func:`jit_cache_dir` (the environment variable, inherited by
    papermill kernels, pytest workers and Dask workers, and numba's config if numba is
    already imported). Must run before the first ``@njit(cache=True)`` of the package is
    decorated: :mod:`vehicle_observers` calls it on import. ``VEHICLE_OBSERVERS_JIT_CACHE=in-tree``
    leaves numba's own choice (``__pycache__`` beside each file). Returns the folder or
    ``None``."""
    if os.environ.get("VEHICLE_OBSERVERS_JIT_CACHE", "") == "in-tree":
        return None
    try:
        d = jit_cache_dir()
    except (OSError, RuntimeError, KeyError):
        # a package file unreadable, or no home folder (a user without a passwd entry):
        # leave numba's default rather than fail the import
        return None
    os.environ["NUMBA_CACHE_DIR"] = str(d)
    cfg = sys.modules.get("numba.core.config")
    if cfg is not None:
        cfg.CACHE_DIR = str(d)
    try:
        if d.is_dir():
            os.utime(d)                 # used now: kept by the pruning of other processes
            prune_jit_caches(d)
    except OSError:
        pass
    return d
