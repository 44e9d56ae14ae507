"""The campaign spec: which sessions, their metadata, configs and analyses (YAML).

Minimum shape (paths relative to the spec file; a session is a path, a glob, or
a mapping with ``path`` and optional ``meta``, ``rig``, ``nvct``, ``namespace``)::

    name: ATF screening
    analyses: [friction, discrepancy]       # and wear for nVCT counts
    settings: {block_s: 1.0, chunk_s: 600}  # optional, see Settings
    groups:
      - rig: rig_A.yaml
        meta: {oil: A}
        sessions:
          - {path: runs/a10.csv, meta: {speed_rpm: 10}}
          - runs/a3*.mcap
      - rig: rig_B.yaml
        nvct: nvct_B.yaml
        meta: {oil: B}
        sessions: [runs/b40.mcap]

A session's kind follows from its file: a bag (rosbag2 directory, ``.mcap``,
``.db3``) holds rig streams and/or ``/nvct/counts``; a CSV whose header starts
with ``t_start`` is an nVCT counts file, any other CSV a rig CSV. The rig
analyses (``friction``, ``discrepancy``) run on sessions with rig data and a
``rig`` config, ``wear`` on sessions with counts and an ``nvct`` config.
Metadata keys become columns of the store's ``sessions`` table (SI units named
in the key, e.g. ``load_N``, ``temperature_C``, ``speed_rpm``, ``stroke_m``,
``frequency_Hz``); values are scalars (a date is kept as its ISO text).
"""

from __future__ import annotations

import datetime
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from tribo_bringup.errors import CampaignError

#: Analyses a campaign can run, and the config each needs.
ANALYSES: dict[str, str] = {'friction': 'rig', 'discrepancy': 'rig', 'wear': 'nvct'}

#: Columns of the ``sessions`` table that metadata keys may not take.
RESERVED = frozenset(
    {
        'session_id',
        'path',
        'kind',
        'key',
        'content_hash',
        'rig',
        'nvct',
        'namespace',
        'analyses',
        'status',
        'error',
        'error_kind',
        'seconds',
        'analysed_at',
        'duration_s',
    }
)

_NAME = re.compile(r'^[A-Za-z_][A-Za-z0-9_]*$')
_BAG_SUFFIXES = ('.mcap', '.db3')
_CSV_SUFFIXES = ('.csv', '.txt')

MetaValue = str | int | float | bool


@dataclass(frozen=True)
class Settings:
    """Analysis settings of a campaign (part of every session's key).

    Attributes
    ----------
    block_s
        Block length of the friction fit [s] (``tribo friction --block``).
    chunk_s
        Length of the time chunks a long session's friction fit is split into [s];
        each chunk is one task.
    discrepancy_start_s
        Start of the discrepancy workflow's window after the first sample [s].
    discrepancy_duration_s
        Length of that window [s] (0: to the end of the session).
    """

    block_s: float = 1.0
    chunk_s: float = 600.0
    discrepancy_start_s: float = 0.0
    discrepancy_duration_s: float = 10.0


#: Accepted range of each setting [s] (inclusive).
_SETTING_RANGES: dict[str, tuple[float, float]] = {
    'block_s': (0.01, 600.0),
    'chunk_s': (1.0, 86_400.0),
    'discrepancy_start_s': (0.0, 1e7),
    'discrepancy_duration_s': (0.0, 1e7),
}


@dataclass(frozen=True)
class SessionSpec:
    """One session of a campaign.

    Attributes
    ----------
    session_id
        Stable name: the path relative to the spec's directory (posix), or absolute.
    path
        Absolute path of the bag or CSV.
    kind
        ``bag``, ``rig_csv`` or ``counts_csv``.
    rig
        RIG.yaml of the session (None: no rig analyses).
    nvct
        NVCT.yaml of the session (None: no wear evaluation).
    namespace
        Rig namespace in a bag ('' : its only rig).
    analyses
        The campaign analyses that apply to this session, in the spec's order.
    meta
        Metadata (group's, then the session's own).
    """

    session_id: str
    path: Path
    kind: str
    rig: Path | None
    nvct: Path | None
    namespace: str
    analyses: tuple[str, ...]
    meta: Mapping[str, MetaValue]


@dataclass(frozen=True)
class CampaignSpec:
    """A loaded campaign spec.

    Attributes
    ----------
    name
        Campaign name.
    source
        The spec file.
    analyses
        Analyses requested.
    settings
        Analysis settings.
    sessions
        Every session, in the spec's order, each once.
    """

    name: str
    source: Path
    analyses: tuple[str, ...]
    settings: Settings
    sessions: tuple[SessionSpec, ...]


def load_spec(path: str | Path) -> CampaignSpec:
    """Read and check a campaign spec.

    Parameters
    ----------
    path : str or Path
        The YAML file.

    Returns
    -------
    CampaignSpec
        Sessions expanded (globs sorted), configs resolved, metadata merged.

    Raises
    ------
    CampaignError
        A missing or unknown key, a glob that matches nothing, a missing file,
        a bad metadata key or value, an analysis without its config (named with
        the spec file and the entry).
    """
    from tribo_common.yamlio import check_keys, load_yaml

    src = Path(path)
    data = load_yaml(src, CampaignError, 'campaign spec')
    if not isinstance(data, dict):
        raise CampaignError(f'{src}: a campaign spec is a mapping with "groups"')
    check_keys(data, ('name', 'analyses', 'settings', 'groups'), str(src), CampaignError)
    analyses = _analyses(data.get('analyses', ['friction']), src)
    settings = _settings(data.get('settings') or {}, src)
    groups = data.get('groups')
    if not isinstance(groups, list) or not groups:
        raise CampaignError(f'{src}: "groups" must be a non-empty list')
    base = src.resolve().parent
    sessions: list[SessionSpec] = []
    seen: set[str] = set()
    for gi, group in enumerate(groups):
        where = f'{src}: groups[{gi}]'
        if not isinstance(group, dict):
            raise CampaignError(f'{where}: expected a mapping with "sessions"')
        check_keys(group, ('rig', 'nvct', 'meta', 'sessions', 'namespace'), where, CampaignError)
        entries = group.get('sessions')
        if isinstance(entries, str):
            entries = [entries]
        if not isinstance(entries, list) or not entries:
            raise CampaignError(f'{where}: "sessions" must be a non-empty list')
        gmeta = _meta(group.get('meta') or {}, where)
        for si, entry in enumerate(entries):
            for s in _sessions(entry, group, gmeta, base, f'{where}.sessions[{si}]', analyses):
                if s.session_id not in seen:
                    seen.add(s.session_id)
                    sessions.append(s)
    name = str(data.get('name') or src.stem)
    return CampaignSpec(name, src, analyses, settings, tuple(sessions))


def _analyses(raw: object, src: Path) -> tuple[str, ...]:
    items = [raw] if isinstance(raw, str) else raw
    if not isinstance(items, list) or not items:
        raise CampaignError(f'{src}: "analyses" must be a non-empty list of {", ".join(ANALYSES)}')
    out: list[str] = []
    for a in items:
        if a not in ANALYSES:
            raise CampaignError(f'{src}: unknown analysis {a!r} (known: {", ".join(ANALYSES)})')
        if a not in out:
            out.append(str(a))
    return tuple(out)


def _settings(raw: object, src: Path) -> Settings:
    from tribo_common.yamlio import check_keys

    if not isinstance(raw, dict):
        raise CampaignError(f'{src}: "settings" must be a mapping')
    check_keys(raw, _SETTING_RANGES, f'{src}: settings', CampaignError)
    values: dict[str, float] = {}
    for k, v in raw.items():
        lo, hi = _SETTING_RANGES[k]
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise CampaignError(f'{src}: settings.{k} must be a number [s], got {v!r}')
        if not lo <= float(v) <= hi:
            raise CampaignError(f'{src}: settings.{k} = {v} s is outside [{lo:g}, {hi:g}] s')
        values[k] = float(v)
    st = Settings(**values)
    if st.chunk_s < 2.0 * st.block_s:
        raise CampaignError(
            f'{src}: settings.chunk_s ({st.chunk_s:g} s) must be at least two blocks '
            f'(2 x block_s = {2 * st.block_s:g} s)'
        )
    return st


def _meta(raw: object, where: str) -> dict[str, MetaValue]:
    if not isinstance(raw, dict):
        raise CampaignError(f'{where}: "meta" must be a mapping of key: value')
    out: dict[str, MetaValue] = {}
    for k, v in raw.items():
        if not isinstance(k, str) or not _NAME.match(k):
            raise CampaignError(
                f'{where}: metadata key {k!r} is not a name (letters, digits, underscore)'
            )
        if k in RESERVED:
            raise CampaignError(f'{where}: metadata key {k!r} is a column of the store')
        if isinstance(v, datetime.date):
            out[k] = v.isoformat()
        elif isinstance(v, str | int | float | bool):
            out[k] = v
        else:
            raise CampaignError(f'{where}: metadata {k!r} must be a single value, got {v!r}')
    return out


def _resolve(base: Path, text: object, where: str, what: str) -> Path:
    if not isinstance(text, str) or not text:
        raise CampaignError(f'{where}: {what} must be a path')
    p = Path(text).expanduser()
    return p if p.is_absolute() else base / p


def _config(value: object, base: Path, where: str, what: str) -> Path | None:
    if value is None:
        return None
    p = _resolve(base, value, where, what)
    if not p.is_file():
        raise CampaignError(f'{where}: {what} {p}: no such file')
    return p


def _sessions(
    entry: object,
    group: Mapping[str, object],
    gmeta: Mapping[str, MetaValue],
    base: Path,
    where: str,
    analyses: tuple[str, ...],
) -> list[SessionSpec]:
    from tribo_common.yamlio import check_keys

    if isinstance(entry, str):
        item: dict[str, object] = {'path': entry}
    elif isinstance(entry, dict):
        item = entry
        check_keys(item, ('path', 'meta', 'rig', 'nvct', 'namespace'), where, CampaignError)
    else:
        raise CampaignError(f'{where}: a session is a path or a mapping with "path"')
    if 'path' not in item:
        raise CampaignError(f'{where}: a session needs a "path"')
    pattern = str(item['path'])
    meta = {**gmeta, **_meta(item.get('meta') or {}, where)}
    rig = _config(item.get('rig', group.get('rig')), base, where, 'rig')
    nvct = _config(item.get('nvct', group.get('nvct')), base, where, 'nvct')
    ns = str(item.get('namespace', group.get('namespace')) or '')
    if any(ch in pattern for ch in '*?['):
        rel = Path(pattern)
        root = rel if rel.is_absolute() else base / rel
        anchor = Path(root.anchor)
        paths = sorted(anchor.glob(str(root.relative_to(anchor))))
        if not paths:
            raise CampaignError(f'{where}: {pattern!r} matches no file')
    else:
        p = _resolve(base, pattern, where, 'path')
        if not p.exists():
            raise CampaignError(f'{where}: {p}: no such file or bag')
        paths = [p]
    out = []
    for p in paths:
        kind = session_kind(p)
        need = 'nvct' if kind == 'counts_csv' else None
        todo = tuple(
            a
            for a in analyses
            if (ANALYSES[a] == 'rig' and rig is not None and kind != 'counts_csv')
            or (ANALYSES[a] == 'nvct' and nvct is not None and kind != 'rig_csv')
        )
        if not todo:
            missing = need or ('rig' if any(ANALYSES[a] == 'rig' for a in analyses) else 'nvct')
            raise CampaignError(
                f'{where}: {p.name}: none of the analyses {", ".join(analyses)} applies '
                f'(a {kind.replace("_", " ")} needs a "{missing}" config)'
            )
        try:
            sid = p.relative_to(base).as_posix()
        except ValueError:
            sid = p.as_posix()
        out.append(SessionSpec(sid, p, kind, rig, nvct, ns, todo, meta))
    return out


def session_kind(path: Path) -> str:
    """Return the kind of a session file: ``bag``, ``rig_csv`` or ``counts_csv``.

    Raises
    ------
    CampaignError
        A file that is neither a bag nor a CSV.
    """
    if path.is_dir() or path.suffix.lower() in _BAG_SUFFIXES:
        return 'bag'
    if path.suffix.lower() not in _CSV_SUFFIXES:
        raise CampaignError(f'{path}: not a bag (.mcap, .db3, directory) or a CSV')
    try:
        with path.open(encoding='utf-8', errors='replace') as fh:
            for line in fh:
                if line.strip() and not line.startswith('#'):
                    return 'counts_csv' if line.lstrip().startswith('t_start') else 'rig_csv'
    except OSError as exc:
        raise CampaignError(f'{path}: cannot read ({exc.strerror})') from exc
    return 'rig_csv'
