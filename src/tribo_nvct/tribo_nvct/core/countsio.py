"""Counts CSV: ``t_start,t_end,counts,live_time`` (s, s, counts, s); ``#`` lines are comments."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from tribo_nvct.core.counting import Dwell
from tribo_nvct.errors import CountsError, CountsFileError

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
