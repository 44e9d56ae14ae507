"""Atomic output directories for the ``tribo`` commands.

Every command that writes results into ``--out DIR`` writes them first into a
hidden staging directory beside it (``.DIR.partial-<pid>``) and moves each
finished file into ``DIR`` only when the whole command succeeded. On any error
(bad input, Ctrl-C, a bug) the staging directory is removed and ``DIR`` holds
exactly what it held before: no file that looks valid but is not.

Usage::

    with atomic_output_dir(out) as stage:
        write_csv(stage / 'blocks.csv', ...)
        plot(stage / 'fig.png')
    # here out/blocks.csv and out/fig.png exist, complete

Files are moved with :func:`os.replace` (atomic on one file system), so a
reader never sees a half-written result file. A file of the same name already
in ``DIR`` is replaced; other files in ``DIR`` are left alone.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


def _staging_path(out: Path) -> Path:
    return out.parent / f'.{out.name}.partial-{os.getpid()}'


@contextmanager
def atomic_output_dir(out: Path | str) -> Iterator[Path]:
    """Yield a staging directory; move its contents into ``out`` on success.

    Parameters
    ----------
    out:
        The results directory the user named (created if needed, only on
        success).

    Yields
    ------
    Path
        An empty staging directory on the same file system as ``out``.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    stage = _staging_path(out)
    if stage.exists():
        shutil.rmtree(stage)
    stage.mkdir()
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    try:
        out.mkdir(parents=True, exist_ok=True)
        for item in sorted(stage.rglob('*')):
            rel = item.relative_to(stage)
            target = out / rel
            if item.is_dir():
                target.mkdir(parents=True, exist_ok=True)
            else:
                target.parent.mkdir(parents=True, exist_ok=True)
                os.replace(item, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


@contextmanager
def atomic_output_file(path: Path | str) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    For commands whose output is one file (``tribo simulate --out FILE.csv``,
    ``tribo campaign --out FIG.png``). On error the temporary file is removed
    and ``path`` is untouched.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.parent / f'.{path.name}.partial-{os.getpid()}{path.suffix}'
    try:
        yield tmp
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if not tmp.exists():
        return
    os.replace(tmp, path)


#: Sub-directory of ``--out`` that receives the results of the good part of a
#: damaged input (a cut bag): never mistaken for the results of the whole input.
PARTIAL_DIR = 'partial'


def keep_as_partial(stage: Path) -> Path:
    """Move everything written into ``stage`` so far into ``stage/partial/``.

    For a command that analysed the good part of a damaged input and will exit
    with an error: on leaving :func:`atomic_output_dir` the results land in
    ``OUT/partial/`` instead of ``OUT/``. Returns the partial directory.
    """
    part = stage / PARTIAL_DIR
    part.mkdir(exist_ok=True)
    for item in sorted(stage.iterdir()):
        if item != part:
            os.replace(item, part / item.name)
    return part
