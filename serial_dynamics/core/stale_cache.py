"""Cached kernels that a change elsewhere made stale are deleted before anything compiles.

Numba keeps a function's compiled entry (``*.nbi`` index, ``*.nbc`` code) while its own
file's contents are unchanged, but the entry holds the machine code of every njit function
it calls or inlines, from other files too: after an edit of a step in ``spatial.py`` or
``joint.py`` a checkout would go on running ``rnea_core``'s cached code, the old step in
it, until that entry is deleted (seen 2026-11-28: a benchmark ran code from before an
edit). ``clear_stale`` keeps one fingerprint (SHA-256 of the sources) in each cache
folder next to the entries and deletes the folder's entries when the sources they may
include changed: DESIGN.md's "the same bits whatever the numba cache holds". A fresh
install has no entries; an unchanged checkout keeps them all (no recompiling).

Called once, from ``core/__init__.py``, before any kernel compiles (they compile on first
use). Processes that start at once take turns (a lock file), so the one that clears does
not delete what the other has just compiled.
"""
from __future__ import annotations

import hashlib
import os
from contextlib import contextmanager
from pathlib import Path

try:
    import fcntl
except ImportError:          # not POSIX: no lock (the worst case is one recompile)
    fcntl = None

PACKAGE = Path(__file__).resolve().parent.parent
# the folders whose modules cache compiled functions: the folders those functions call into
INCLUDES = {"core": ("core",), "sim": ("core", "sim"), "robot": ("core", "robot")}
STAMP = "serial_dynamics-sources.sha256"


def fingerprint(package: Path, folders, digests=None) -> str:
    """SHA-256 over the names and contents of every ``*.py`` in ``folders`` of ``package``:
    over each folder's own digest, kept in ``digests`` (folder: digest) so that a folder
    that several fingerprints include (``core``) is read once."""
    digests = {} if digests is None else digests
    h = hashlib.sha256()
    for folder in folders:
        if folder not in digests:
            d = hashlib.sha256()
            for f in sorted((package / folder).glob("*.py")):
                d.update(f"{f.name}\0".encode())
                d.update(f.read_bytes())
            digests[folder] = d.digest()
        h.update(f"{folder}\0".encode())
        h.update(digests[folder])
    return h.hexdigest()


def cache_folder(source: Path) -> Path | None:
    """Where numba caches the functions of the module ``source``: the first of its cache
    locators that applies (NUMBA_CACHE_DIR, the module's ``__pycache__`` when writable,
    the user's cache folder), as numba picks it; None if none applies."""
    try:
        from numba.core.caching import CacheImpl
        locators = CacheImpl._locator_classes
    except (ImportError, AttributeError):        # another numba: its in-tree default
        return source.parent / "__pycache__"

    def anchor():            # a function of that file (the locators read its line number)
        pass
    for locator in locators:
        found = locator.from_function(anchor, str(source))
        if found is not None:
            return Path(found.get_cache_path())
    return None


def clear_stale(package: Path = PACKAGE, includes=INCLUDES) -> list[str]:
    """Delete the cached entries of each folder in ``includes`` whose sources (its own and
    those it calls into) changed since its fingerprint was written, or that has entries and
    no fingerprint; write the fingerprint. Returns the folders cleared. A cache folder that
    cannot be written is left alone (numba then caches nothing there either)."""
    cleared, digests = [], {}
    for folder, sources in includes.items():
        modules = sorted((package / folder).glob("*.py"))
        where = cache_folder(modules[0]) if modules else None
        if where is None or not where.is_dir():
            continue
        try:
            with _locked(where / (STAMP + ".lock")):
                if _clear(where, {m.stem for m in modules},
                          fingerprint(package, sources, digests)):
                    cleared.append(folder)
        except OSError:
            continue
    return cleared


def _clear(where: Path, stems, now: str) -> bool:
    """Delete the entries of the modules ``stems`` in ``where`` unless its fingerprint is
    ``now``; write ``now``. True if entries were deleted."""
    stamp = where / STAMP
    if stamp.is_file() and stamp.read_text() == now:
        return False
    entries = [f for f in where.iterdir()
               if f.suffix in (".nbi", ".nbc") and f.name.split(".", 1)[0] in stems]
    for f in entries:
        f.unlink(missing_ok=True)
    tmp = where / f"{STAMP}.{os.getpid()}"
    tmp.write_text(now)
    os.replace(tmp, stamp)                 # atomic: a reader sees the old or the new
    return bool(entries)


@contextmanager
def _locked(path: Path):
    """An exclusive lock on ``path`` for the ``with`` block (none where fcntl is missing)."""
    with open(path, "a") as f:
        if fcntl is not None:
            fcntl.flock(f, fcntl.LOCK_EX)          # released when f closes
        yield
