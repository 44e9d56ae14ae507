"""The campaign store: Parquet tables and a DuckDB database with views over them.

Layout of ``STORE/``::

    campaign.duckdb         views sessions, blocks, discrepancy, wear, provenance
    sessions.parquet        the spec's sessions (id, path, key, metadata columns)
    results/<key>/          one directory per analysed session key:
        provenance.parquet  status (ok / failed), error, seconds, versions, settings
        blocks.parquet      friction blocks (one row per block)
        discrepancy.parquet missing-physics verdict (one row)
        wear.parquet        nVCT wear summary (one row)
    results/_empty/         the same tables without rows (so every view binds)
    .lock                   held by the run that writes (pid inside)

A session's results are keyed by :func:`session_key`: its content hash, its
configs' hashes, the analysis settings and the software versions. A result
directory is written as ``results/.tmp-<key>-<pid>/`` (every file flushed to
disk) and renamed into place in one step, so a killed run, a Ctrl-C or a power
cut leaves either the whole session or nothing of it; leftovers of a dead run
are removed by the next. The views join the tables on ``key`` through
``sessions.parquet``, so they show the current spec's sessions only; a session
without a result is ``pending``. ``sessions.parquet`` and ``campaign.duckdb``
are replaced atomically too. One run at a time: :meth:`Store.lock` takes an
exclusive ``flock`` on ``.lock`` (released by the OS when the process dies).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import shutil
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import fields
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from tribo_bringup.errors import CampaignError, StoreBusyError

from .analyses import WEAR_COLUMNS, Cell, Row

if TYPE_CHECKING:
    import duckdb
    import pyarrow as pa

T = TypeVar('T')

DB_NAME = 'campaign.duckdb'
SESSIONS_FILE = 'sessions.parquet'
RESULTS_DIR = 'results'
EMPTY_KEY = '_empty'
LOCK_FILE = '.lock'

#: Version of the store's table layout (part of every key: a new layout re-analyses).
LAYOUT_VERSION = '2'

#: Column types of the per-key tables besides ``key``: ``float``, ``int``, ``str``, ``bool``.
#: The blocks columns are the fields of :class:`~tribo_estimation.core.blockfit.BlockResult`.
RESULT_TABLES: tuple[str, ...] = ('provenance', 'blocks', 'discrepancy', 'wear')

_PROVENANCE_COLUMNS: dict[str, str] = {
    'status': 'str',
    'error': 'str',
    'error_kind': 'str',
    'seconds': 'float',
    'analysed_at': 'str',
    'software': 'str',
    'settings': 'str',
    'content_hash': 'str',
}
_DISCREPANCY_COLUMNS: dict[str, str] = {
    'window_start_s': 'float',
    'window_s': 'float',
    'verdict': 'str',
    'finding': 'str',
    'reason': 'str',
    'experiment': 'str',
    'added': 'str',
    'cannot_tell_apart': 'str',
    'n_unexplained': 'int',
    'rms_baseline': 'float',
    'rms_final': 'float',
    'noise_floor': 'float',
    'mu0': 'float',
    'mu_inf': 'float',
    'result_json': 'str',
}
_WEAR_COLUMNS: dict[str, str] = {
    'dwells': 'int',
    'load_N': 'float',
    'stroke_m': 'float',
    'frequency_hz': 'float',
    'temperature_K': 'float',
    **dict.fromkeys(WEAR_COLUMNS, 'float'),
    'sliding_distance_convention': 'str',
}


def table_columns(table: str) -> dict[str, str]:
    """Return the columns (name -> ``float``/``int``/``str``/``bool``) of a per-key table.

    Parameters
    ----------
    table : str
        One of :data:`RESULT_TABLES`.

    Returns
    -------
    dict
        Column types, ``key`` first.
    """
    if table == 'blocks':
        from tribo_estimation.core.blockfit import BlockResult

        kinds = {'int': 'int', 'float': 'float', 'str': 'str'}
        cols = {f.name: kinds.get(str(f.type), 'str') for f in fields(BlockResult)}
        return {'key': 'str', 'chunk': 'int', **cols}
    spec = {
        'provenance': _PROVENANCE_COLUMNS,
        'discrepancy': _DISCREPANCY_COLUMNS,
        'wear': _WEAR_COLUMNS,
    }[table]
    return {'key': 'str', **spec}


def _arrow_type(kind: str) -> pa.DataType:
    import pyarrow as pa

    return {'float': pa.float64(), 'int': pa.int64(), 'bool': pa.bool_()}.get(kind, pa.string())


def _table(rows: Sequence[Mapping[str, Cell]], columns: Mapping[str, str]) -> pa.Table:
    """Build an Arrow table with the given column types (missing cells null)."""
    import pyarrow as pa

    arrays = {}
    for name, kind in columns.items():
        vals = [r.get(name) for r in rows]
        if kind == 'str':
            vals = [None if v is None else str(v) for v in vals]
        arrays[name] = pa.array(vals, type=_arrow_type(kind))
    return pa.table(arrays)


def _meta_table(rows: Sequence[Mapping[str, Cell]]) -> pa.Table:
    """Build the sessions table: fixed columns, then one column per metadata key."""
    import pyarrow as pa

    names: list[str] = list(SESSION_COLUMNS)
    for r in rows:
        names.extend(k for k in r if k not in names)
    arrays = {}
    for name in names:
        vals = [r.get(name) for r in rows]
        kind = SESSION_COLUMNS.get(name)
        if kind is None:  # metadata: one type per column, text when the values mix
            types = {type(v) for v in vals if v is not None}
            if types <= {int} and types:
                kind = 'int'
            elif types <= {int, float} and types:
                kind = 'float'
            elif types == {bool}:
                kind = 'bool'
            else:
                kind = 'str'
        if kind == 'str':
            vals = [None if v is None else str(v) for v in vals]
        elif kind == 'float':
            vals = [None if v is None else float(v) for v in vals]
        arrays[name] = pa.array(vals, type=_arrow_type(kind))
    return pa.table(arrays)


#: Fixed columns of ``sessions.parquet``.
SESSION_COLUMNS: dict[str, str] = {
    'session_id': 'str',
    'path': 'str',
    'kind': 'str',
    'key': 'str',
    'content_hash': 'str',
    'file_size': 'int',
    'file_mtime_ns': 'int',
    'rig': 'str',
    'nvct': 'str',
    'namespace': 'str',
    'analyses': 'str',
    'duration_s': 'float',
}


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _write_parquet(table: pa.Table, path: Path) -> None:
    """Write a Parquet file and flush it to disk (the caller renames it into place)."""
    import pyarrow.parquet as pq

    pq.write_table(table, path)
    with path.open('rb') as fh:
        os.fsync(fh.fileno())


def file_fingerprint(path: Path) -> tuple[int, int]:
    """Return (total size [bytes], newest modification time [ns]) of a file or bag directory.

    Parameters
    ----------
    path : Path
        A file or a directory (its files, recursively).

    Returns
    -------
    tuple[int, int]
        Size and mtime; a change of either means the content is hashed again.
    """
    files = [path] if path.is_file() else sorted(p for p in path.rglob('*') if p.is_file())
    size, mtime = 0, 0
    for f in files:
        st = f.stat()
        size += st.st_size
        mtime = max(mtime, st.st_mtime_ns)
    return size, mtime


def content_hash(path: Path) -> str:
    """Return the SHA-256 of a session's bytes (a bag directory: names and bytes of its files).

    Parameters
    ----------
    path : Path
        A file or a bag directory.

    Returns
    -------
    str
        Hex digest.
    """
    h = hashlib.sha256()
    files = [path] if path.is_file() else sorted(p for p in path.rglob('*') if p.is_file())
    for f in files:
        if not path.is_file():
            h.update(f.relative_to(path).as_posix().encode() + b'\0')
        with f.open('rb') as fh:
            while chunk := fh.read(1 << 20):
                h.update(chunk)
    return h.hexdigest()


def session_key(
    content: str, configs: Sequence[str], analyses: Sequence[str], settings: str, software: str
) -> str:
    """Return the store key of a session's results.

    Parameters
    ----------
    content : str
        Content hash of the session.
    configs : sequence of str
        Content hashes of its rig and nVCT configs ('' for none).
    analyses : sequence of str
        The analyses that apply to it.
    settings : str
        The campaign's analysis settings (JSON).
    software : str
        Software versions (JSON) and :data:`LAYOUT_VERSION`.

    Returns
    -------
    str
        32 hex digits.
    """
    text = json.dumps([content, list(configs), list(analyses), settings, software, LAYOUT_VERSION])
    return hashlib.sha256(text.encode()).hexdigest()[:32]


class Store:
    """A campaign store directory (see the module docstring for the layout).

    Parameters
    ----------
    root : str or Path
        The store directory (created by :meth:`lock`).
    """

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root).resolve()

    @property
    def results(self) -> Path:
        """Directory of the per-key results."""
        return self.root / RESULTS_DIR

    # ---------------------------------------------------------------- locking
    @contextlib.contextmanager
    def lock(self) -> Iterator[Store]:
        """Hold the store for one run; clean up what a dead run left.

        Yields
        ------
        Store
            This store, locked.

        Raises
        ------
        StoreBusyError
            Another process holds the store.
        """
        self.root.mkdir(parents=True, exist_ok=True)
        path = self.root / LOCK_FILE
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors='replace').strip() or '?'
            os.close(fd)
            raise StoreBusyError(
                f'{self.root}: another campaign run (pid {holder}) is writing this store; '
                'wait for it to end or use another --store'
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f'{os.getpid()}\n'.encode(), 0)
        try:
            self._prepare()
            yield self
        finally:
            os.ftruncate(fd, 0)
            os.close(fd)

    def _prepare(self) -> None:
        """Remove a dead run's leftovers; make the empty tables every view needs."""
        self.results.mkdir(exist_ok=True)
        for p in self.results.iterdir():
            if p.name.startswith('.tmp-'):
                shutil.rmtree(p, ignore_errors=True)
        for p in self.root.iterdir():
            if p.name.startswith('.') and p.name.endswith('.partial'):
                p.unlink(missing_ok=True)
        if not (self.results / EMPTY_KEY).is_dir():
            self.commit(EMPTY_KEY, {})

    # ---------------------------------------------------------------- writing
    def committed(self) -> dict[str, tuple[str, str]]:
        """Return every committed key with its (status, error kind).

        Returns
        -------
        dict
            key -> (``ok`` or ``failed``, ``input``/``internal``/``''``).
        """
        import pyarrow.parquet as pq

        out: dict[str, tuple[str, str]] = {}
        if not self.results.is_dir():
            return out
        for d in self.results.iterdir():
            if d.name.startswith('.') or d.name == EMPTY_KEY:
                continue
            prov = d / 'provenance.parquet'
            if not prov.is_file():
                continue
            rows = pq.read_table(prov, columns=['status', 'error_kind']).to_pylist()
            if rows:
                out[d.name] = (str(rows[0]['status']), str(rows[0]['error_kind'] or ''))
        return out

    def failures(self, sessions: Sequence[tuple[T, str]]) -> list[tuple[T, str]]:
        """Return the sessions whose committed result is failed, with the error line.

        Parameters
        ----------
        sessions : sequence of (item, key)
            Anything paired with its session key.

        Returns
        -------
        list of (item, error)
            In the given order.
        """
        import pyarrow.parquet as pq

        out: list[tuple[T, str]] = []
        for item, key in sessions:
            prov = self.results / key / 'provenance.parquet'
            if not prov.is_file():
                continue
            rows = pq.read_table(prov, columns=['status', 'error']).to_pylist()
            if rows and rows[0]['status'] == 'failed':
                out.append((item, str(rows[0]['error'])))
        return out

    def commit(self, key: str, tables: Mapping[str, Sequence[Row]]) -> bool:
        """Write one session's results atomically.

        Parameters
        ----------
        key : str
            The session key.
        tables : mapping
            Table name -> rows (``provenance`` one row; the others any number);
            a table not given is written empty.

        Returns
        -------
        bool
            False when the key was committed already (nothing written).
        """
        final = self.results / key
        if final.is_dir() and key != EMPTY_KEY:
            return False
        tmp = self.results / f'.tmp-{key}-{os.getpid()}'
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir(parents=True)
        for name in RESULT_TABLES:
            rows = [{**r, 'key': key} for r in tables.get(name, ())]
            _write_parquet(_table(rows, table_columns(name)), tmp / f'{name}.parquet')
        _fsync_dir(tmp)
        if final.is_dir():  # only the empty tables are ever rewritten
            shutil.rmtree(final)
        os.rename(tmp, final)
        _fsync_dir(self.results)
        return True

    def discard(self, key: str) -> None:
        """Remove a committed key's results (a session tried again after an internal error).

        Parameters
        ----------
        key : str
            The session key.
        """
        final = self.results / key
        if final.is_dir():
            trash = self.results / f'.tmp-discard-{key}-{os.getpid()}'
            os.rename(final, trash)
            shutil.rmtree(trash, ignore_errors=True)

    def write_sessions(self, rows: Sequence[Mapping[str, Cell]]) -> None:
        """Replace ``sessions.parquet`` atomically and rebuild the views.

        Parameters
        ----------
        rows : sequence of mapping
            One row per session (:data:`SESSION_COLUMNS` and its metadata).
        """
        tmp = self.root / f'.{SESSIONS_FILE}.{os.getpid()}.partial'
        _write_parquet(_meta_table(rows), tmp)
        os.replace(tmp, self.root / SESSIONS_FILE)
        _fsync_dir(self.root)
        self.write_views()

    def previous_sessions(self) -> dict[str, Row]:
        """Return the last run's session rows by path (for the content-hash cache).

        Returns
        -------
        dict
            path -> row of ``sessions.parquet`` (empty for a new store).
        """
        import pyarrow.parquet as pq

        f = self.root / SESSIONS_FILE
        if not f.is_file():
            return {}
        return {str(r['path']): r for r in pq.read_table(f).to_pylist()}

    def write_views(self) -> None:
        """Write ``campaign.duckdb`` with the views over the Parquet tables (atomic replace)."""
        import duckdb

        tmp = self.root / f'.{DB_NAME}.{os.getpid()}.partial'
        tmp.unlink(missing_ok=True)
        con = duckdb.connect(str(tmp))
        try:
            for sql in self.view_statements():
                con.execute(sql)
            con.execute('CHECKPOINT')
        finally:
            con.close()
        os.replace(tmp, self.root / DB_NAME)
        _fsync_dir(self.root)

    def view_statements(self) -> list[str]:
        """Return the ``CREATE VIEW`` statements of the store (absolute paths).

        Returns
        -------
        list of str
            SQL, one view each: ``sessions``, ``provenance``, ``blocks``,
            ``discrepancy``, ``wear``.
        """
        sess = _sql_str(str(self.root / SESSIONS_FILE))

        def part(table: str) -> str:
            glob = _sql_str(str(self.results / '*' / f'{table}.parquet'))
            return f'read_parquet({glob}, union_by_name = true)'

        stmts = [
            f'CREATE VIEW provenance AS SELECT * FROM {part("provenance")} '
            f"WHERE key <> '{EMPTY_KEY}'",
            'CREATE VIEW sessions AS SELECT s.*, '
            "coalesce(p.status, 'pending') AS status, p.error, p.error_kind, p.seconds, "
            'p.analysed_at '
            f'FROM read_parquet({sess}) s LEFT JOIN provenance p ON p.key = s.key',
        ]
        order = {'blocks': 'b.t_start', 'discrepancy': 's.session_id', 'wear': 's.session_id'}
        for table, by in order.items():
            stmts.append(
                f'CREATE VIEW {table} AS SELECT s.session_id, b.* EXCLUDE (key) '
                f'FROM {part(table)} b JOIN read_parquet({sess}) s ON s.key = b.key '
                f'ORDER BY s.session_id, {by}'
            )
        return stmts

    # ---------------------------------------------------------------- reading
    def connect(self) -> duckdb.DuckDBPyConnection:
        """Open ``campaign.duckdb`` read-only.

        Returns
        -------
        duckdb.DuckDBPyConnection
            A connection (close it after use).

        Raises
        ------
        CampaignError
            No store at this path.
        """
        import duckdb

        db = self.root / DB_NAME
        if not db.is_file():
            raise CampaignError(
                f'{self.root}: not a campaign store (no {DB_NAME}; run `tribo campaign analyse`)'
            )
        return duckdb.connect(str(db), read_only=True)


def _sql_str(text: str) -> str:
    return "'" + text.replace("'", "''") + "'"
