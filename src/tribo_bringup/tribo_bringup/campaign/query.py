"""SQL on a campaign store: rows in memory, a printed table, or a CSV / Parquet file.

The statement runs on ``STORE/campaign.duckdb`` opened read-only (its views:
``sessions``, ``blocks``, ``discrepancy``, ``wear``, ``provenance``); an export
is written beside its target and renamed onto it when complete.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from tribo_bringup.errors import CampaignError

from .analyses import Cell
from .store import Store


def query(store: str | Path, sql: str) -> tuple[list[str], list[tuple[Cell, ...]]]:
    """Run one SQL statement on the store.

    Parameters
    ----------
    store : str or Path
        The store directory.
    sql : str
        The statement (read-only).

    Returns
    -------
    tuple
        Column names and rows.

    Raises
    ------
    CampaignError
        No store there, or the statement fails (DuckDB's first line).
    """
    import duckdb

    con = Store(store).connect()
    try:
        rel = con.execute(sql)
        cols = [d[0] for d in rel.description or ()]
        rows = [tuple(r) for r in rel.fetchall()]
    except duckdb.Error as exc:
        raise CampaignError(f'query: {_first_line(exc)}') from None
    finally:
        con.close()
    return cols, rows


def export(store: str | Path, sql: str, out: str | Path, fmt: str) -> int:
    """Write a statement's result to a CSV or Parquet file.

    Parameters
    ----------
    store : str or Path
        The store directory.
    sql : str
        A SELECT statement.
    out : str or Path
        The file to write (replaced when complete).
    fmt : str
        ``csv`` or ``parquet``.

    Returns
    -------
    int
        Rows written.

    Raises
    ------
    CampaignError
        No store there, or the statement fails.
    """
    import duckdb

    target = Path(out)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.parent / f'.{target.name}.partial-{os.getpid()}'
    con = Store(store).connect()
    try:
        body = sql.strip().rstrip(';')
        path = "'" + str(tmp).replace("'", "''") + "'"
        options = '(FORMAT csv, HEADER true)' if fmt == 'csv' else '(FORMAT parquet)'
        con.execute(f'COPY ({body}) TO {path} {options}')
        n = con.execute(f'SELECT count(*) FROM ({body})').fetchone()
    except duckdb.Error as exc:
        tmp.unlink(missing_ok=True)
        raise CampaignError(f'query: {_first_line(exc)}') from None
    finally:
        con.close()
    os.replace(tmp, target)
    return int(n[0]) if n else 0


def format_table(cols: list[str], rows: list[tuple[Cell, ...]], max_rows: int = 200) -> str:
    """Format rows as an aligned text table (floats with 6 significant digits).

    Parameters
    ----------
    cols : list of str
        Column names.
    rows : list of tuple
        Rows.
    max_rows : int
        Rows shown (the rest counted in a last line).

    Returns
    -------
    str
        The table, one line per row.
    """

    def cell(v: Cell) -> str:
        if v is None:
            return ''
        if isinstance(v, float):
            return f'{v:.6g}' if math.isfinite(v) else str(v)
        return str(v)

    shown = [[cell(v) for v in r] for r in rows[:max_rows]]
    widths = [max([len(c)] + [len(r[i]) for r in shown]) for i, c in enumerate(cols)]
    lines = ['  '.join(c.ljust(w) for c, w in zip(cols, widths, strict=True)).rstrip()]
    lines.append('  '.join('-' * w for w in widths))
    lines.extend(
        '  '.join(v.ljust(w) for v, w in zip(r, widths, strict=True)).rstrip() for r in shown
    )
    if len(rows) > max_rows:
        lines.append(f'... {len(rows) - max_rows} more rows (use --csv or --parquet)')
    lines.append(f'({len(rows)} rows)')
    return '\n'.join(lines)


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
