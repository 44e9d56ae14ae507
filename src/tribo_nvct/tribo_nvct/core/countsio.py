"""Detector counts in: a counts CSV or the ``/nvct/counts`` messages of a bag.

Counts CSV: ``t_start,t_end,counts,live_time`` (s, s, counts, s); ``#`` lines are
comments. :func:`read_counts` reads either into :class:`Counts`; every dwell is
validated (:class:`~tribo_nvct.core.counting.Dwell`) and an error names the file and
the line or message.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from tribo_nvct.core.counting import Dwell
from tribo_nvct.errors import (
    CountsBagError,
    CountsError,
    CountsFileError,
    CountsTruncatedError,
)

COLUMNS = ('t_start', 't_end', 'counts', 'live_time')


def read_counts_csv(path: str | Path) -> list[Dwell]:
    """Read and validate the dwells of a counts CSV (errors name file and line)."""
    p = Path(path)
    try:
        lines = p.read_text(encoding='utf-8').splitlines()
    except OSError as exc:
        raise CountsFileError(f'cannot read counts file {p}: {exc.strerror}') from None
    except UnicodeDecodeError as exc:
        raise CountsFileError(f'{p}: not a UTF-8 text counts file (byte {exc.start})') from None
    body = [
        (n, ln) for n, ln in enumerate(lines, 1) if ln.strip() and not ln.lstrip().startswith('#')
    ]
    if not body:
        raise CountsFileError(f'{p}: no header and no data')
    header = [h.strip() for h in next(csv.reader([body[0][1]]))]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise CountsFileError(f'{p}: missing column(s) {missing} (have {header})')
    idx = [header.index(c) for c in COLUMNS]
    out: list[Dwell] = []
    for n, ln in body[1:]:
        row = next(csv.reader([ln]))
        try:
            t0, t1, c, lt = (row[i].strip() for i in idx)
            cf = float(c)
            vals = (float(t0), float(t1), float(lt))
        except (IndexError, ValueError):
            raise CountsFileError(f'{p}: line {n}: bad or missing value: {ln!r}') from None
        if not all(math.isfinite(v) for v in (*vals, cf)):
            raise CountsFileError(f'{p}: line {n}: NaN or infinite value')
        try:
            d = Dwell(vals[0], vals[1], int(cf) if cf == int(cf) else cf, vals[2])  # type: ignore[arg-type]
        except CountsError as exc:
            raise type(exc)(f'{p}: line {n}: {exc}') from None
        out.append(d)
    if not out:
        raise CountsFileError(f'{p}: no data rows')
    return out


@dataclass(frozen=True)
class Counts:
    """The dwells of one nVCT test, as read.

    Attributes
    ----------
    dwells : tuple of Dwell
        One per detector dwell (test time [s], counts, live time [s]).
    source : str
        The file or bag read.
    truncated : str
        The error of a bag that ends early ('' if none): the dwells before it.
    """

    dwells: tuple[Dwell, ...]
    source: str
    truncated: str = ''

    def __len__(self) -> int:
        """Return the number of dwells."""
        return len(self.dwells)


def _bag_dwells(path: Path) -> tuple[list[Dwell], str]:
    """Read the dwells of ``/nvct/counts`` in a bag, and the damage of one that ends early."""
    from tribo_common import topics
    from tribo_common.bag_read import iter_messages
    from tribo_common.errors import BagError, BagTruncatedError

    topic = topics.NVCT_COUNTS.resolve()
    out: list[Dwell] = []
    truncated = ''
    try:
        for m in iter_messages(path, [topic]):
            msg = m.msg
            try:
                out.append(
                    Dwell(
                        float(msg.t_start), float(msg.t_end), int(msg.counts), float(msg.live_time)
                    )
                )
            except CountsError as exc:
                raise type(exc)(f'{path}: message #{m.index}: {exc}') from None
    except BagTruncatedError as exc:
        truncated = str(exc)
    except BagError as exc:
        raise CountsBagError(str(exc)) from None
    if not out:
        raise (
            CountsTruncatedError(truncated)
            if truncated
            else CountsBagError(f'{path}: no {topic} messages')
        )
    return out, truncated


def read_counts(path: str | Path, *, keep_truncated: bool = False) -> Counts:
    """Read the dwells of a counts CSV or of a bag's ``/nvct/counts``.

    Parameters
    ----------
    path : str or Path
        Counts CSV (``.csv``, ``.txt``) or a bag directory / ``.mcap`` file.
    keep_truncated : bool
        A bag that ends early gives the dwells before the damage
        (``Counts.truncated`` names it) instead of raising.

    Returns
    -------
    Counts
        The validated dwells.

    Raises
    ------
    CountsFileError
        The CSV cannot be read, lacks a column or holds a bad value (names the line).
    CountsError
        A dwell is invalid (negative counts, live time beyond the dwell, ...).
    CountsBagError
        No such file or bag, or a bag without ``/nvct/counts``;
        :class:`~tribo_nvct.errors.CountsTruncatedError` for a bag that ends early
        (unless ``keep_truncated``).
    """
    p = Path(path)
    if not p.exists():
        raise CountsBagError(f'{p}: no such file or bag')
    if p.is_file() and p.suffix.lower() in ('.csv', '.txt'):
        return Counts(tuple(read_counts_csv(p)), str(p))
    dwells, truncated = _bag_dwells(p)
    if truncated and not keep_truncated:
        raise CountsTruncatedError(truncated)
    return Counts(tuple(dwells), str(p), truncated)
