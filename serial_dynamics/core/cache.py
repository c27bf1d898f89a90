"""Where numba caches the compiled kernels: one folder per fingerprint of their sources.

Numba keys a cached function on its own file (in numba 0.68 a SHA-256 of that file), but
the entry holds the machine code of every njit function it calls or inlines, from other
files too: after an edit of a step in ``spatial.py`` a cached ``rnea_core`` would go on
running the old step. So the package's compiled functions are cached in a folder named by
a fingerprint (SHA-256) of every source they may include: ``core`` holds core/'s
functions (fingerprint of core/), ``sim``, ``robot`` and ``contacts`` theirs (of core/ and
their own folder). An edit makes a new fingerprint, hence a new, empty folder, and the next process
compiles afresh; a checkout that changed nothing finds its folder full. Nothing is deleted
at import: DESIGN.md's "the same bits whatever the numba cache holds" holds because a
folder only ever holds code built from the sources its name says. ``precompile`` removes
the folders of other fingerprints (``prune``).

The means is numba's documented ``NUMBA_CACHE_DIR`` (``numba.config.CACHE_DIR``), set to
the folder only while ``in_folder`` decorates the package's functions (numba picks a
function's cache folder when it is decorated; other libraries' functions keep theirs).
The folders lie under the user's ``NUMBA_CACHE_DIR`` when it is set, else under the
package's ``__pycache__`` when that is writable, else under the user's cache folder
(``$XDG_CACHE_HOME`` or ``~/.cache``, in ``serial_dynamics``).
"""
from __future__ import annotations

import hashlib
import os
import shutil
from contextlib import contextmanager
from pathlib import Path

from numba import config, njit

PACKAGE = Path(__file__).resolve().parent.parent
INCLUDES = {"core": ("core",), "sim": ("core", "sim"), "robot": ("core", "robot"),
            "contacts": ("core", "contacts")}
PREFIX = "serial_dynamics-"
_FOLDERS = {}          # (package, name): its folder (computed once a process)
_DIGESTS = {}          # package: {source folder: digest}


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


def base(user=None) -> Path | None:
    """The folder that holds the fingerprinted folders (the module docstring's order);
    None when none is writable (numba's own locators then apply)."""
    user = config.CACHE_DIR if user is None else user
    home = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    for where in ([Path(user)] if user else []) + [PACKAGE / "__pycache__",
                                                    Path(home) / "serial_dynamics"]:
        try:
            where.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(where, os.W_OK):
            return where
    return None


def folder(name: str, package: Path = PACKAGE, includes=INCLUDES) -> Path | None:
    """The cache folder of the functions of ``package``'s folder ``name`` (a key of
    ``includes``: the source folders they may include); None where ``base`` is."""
    key = (package, name)
    if key not in _FOLDERS:
        root = base()
        fp = fingerprint(package, includes[name], _DIGESTS.setdefault(package, {}))
        _FOLDERS[key] = None if root is None else root / f"{PREFIX}{name}-{fp[:20]}"
    return _FOLDERS[key]


@contextmanager
def in_folder(name: str, package: Path = PACKAGE, includes=INCLUDES):
    """Functions decorated with ``cache=True`` in the block are cached in ``folder``."""
    where, saved = folder(name, package, includes), config.CACHE_DIR
    if where is not None:
        config.CACHE_DIR = str(where)
    try:
        yield where
    finally:
        config.CACHE_DIR = saved


def njit_in(name: str, *sigs, **options):
    """``numba.njit(*sigs, cache=True, **options)``, cached in ``folder(name)``: for the
    functions of ``sim/`` and ``robot/`` (core/'s are decorated in ``core/__init__``'s block)."""
    def decorate(func):
        with in_folder(name):
            return njit(*sigs, cache=True, **options)(func)
    return decorate


def prune() -> list[Path]:
    """Remove the cache folders of other fingerprints than this checkout's (under ``base``);
    returns them. Run by ``precompile``, never at import."""
    root = base()
    keep = {folder(name) for name in INCLUDES}
    if root is None:
        return []
    gone = [f for f in root.glob(PREFIX + "*") if f.is_dir() and f not in keep]
    for f in gone:
        shutil.rmtree(f, ignore_errors=True)
    return gone
