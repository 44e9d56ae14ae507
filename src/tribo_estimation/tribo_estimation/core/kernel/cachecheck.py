"""Drop numba's on-disk caches of the package when compiled code changed.

numba's cache (``cache=True``) keys a compiled function on its own source file only.
The kernel's layout constants (:mod:`.layout`: indices and sizes of the parameter,
state and output vectors) and every compiled function are compiled *into* the
functions that use them, in other files (``inline='always'``, or a call the compiler
resolves at compile time): after an edit of ``layout.py`` (a new state slot) or of a
compiled function (``kernel.equations``' drive, say), the functions of other files
would load stale machine code. So the package's caches are deleted when the hash of
``layout.py`` and of every source holding compiled code (its text names ``njit``)
differs from the one stamped at the last check. Runs once per process, before any
compiled function is loaded (about 5 ms); a read-only install is left alone.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

#: Kernel files compiled into functions defined elsewhere that hold no compiled code.
_SHARED = ('layout.py',)
#: The text that marks a source holding compiled code.
_COMPILED = b'njit'
_STAMP = 'compiled.sha256'
_STAMP_ALL = 'sources.sha256'


def _digest(files: list[tuple[Path, bytes]], base: Path) -> str:
    h = hashlib.sha256()
    for src, text in files:
        h.update(str(src.relative_to(base)).encode())
        h.update(text)
    return h.hexdigest()


def purge_stale_caches(kernel_dir: Path | None = None, *, every_source: bool = False) -> bool:
    """Delete the package's numba cache files if compiled code changed.

    Parameters
    ----------
    kernel_dir : Path, optional
        The kernel package's folder (default: this one); the package whose caches
        are deleted is two levels up (``tribo_estimation/``).
    every_source : bool
        Hash every ``.py`` file of the package instead of the compiled ones (the
        set-up's warm-up: any change of a source drops the caches; own stamp).

    Returns
    -------
    bool
        True if cache files were deleted (compiled code changed since the last
        check).
    """
    here = kernel_dir if kernel_dir is not None else Path(__file__).resolve().parent
    package = here.parents[1]  # tribo_estimation/
    stamp = here / '__pycache__' / (_STAMP_ALL if every_source else _STAMP)
    try:
        sources = [(f, f.read_bytes()) for f in sorted(package.rglob('*.py'))]
        files = (
            sources
            if every_source
            else [
                (f, text) for f, text in sources
                if (f.parent == here and f.name in _SHARED) or _COMPILED in text
            ]
        )  # fmt: skip
        digest = _digest(files, package)
        if stamp.is_file() and stamp.read_text().strip() == digest:
            return False
        roots = [package]
        extra = os.environ.get('NUMBA_CACHE_DIR')
        if extra:
            roots.append(Path(extra))
        purged = False
        for root in roots:
            for pattern in ('*.nbi', '*.nbc'):
                for f in root.rglob(pattern):
                    if root is package or 'tribo_estimation' in f.parts:
                        f.unlink(missing_ok=True)
                        purged = True
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest + '\n')
        return purged
    except OSError:  # a read-only install: its caches were built from these files
        return False


# at import, i.e. first in the kernel package, before any compiled function is loaded
purge_stale_caches()
