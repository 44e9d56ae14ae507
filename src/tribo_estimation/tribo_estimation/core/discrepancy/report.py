"""``discrepancy.json``: the report of the missing-physics pipeline.

Layout (rms values of the torsion-moment residual, measured - simulated [N m];
adequacy statistics dimensionless, :mod:`.pipeline.null`)::

    {"verdict": "nothing_missing" | "named" | "cannot_tell_apart" | "unexplained"
                | "instrument",
     "finding": one line, "reason": one sentence, "experiment": what would decide,
     "added": [{"family", "form", "effect", "params", "se", "units", "rms",
                "statistic", "explained", "failing", "at_bound"}, ...],
     "cannot_tell_apart": [...same...], "partial": [...same...],
     "baseline": {"rms", "params"}, "final": {"rms", "params"},
     "noise_floor", "unexplained": [{"kind", "where", "size", "unit", "frequency"}],
     "instrument", "drive",
     "records": [{"baseline": {"params", "rms", "statistics"}, "final": {...},
                  "noise_floor", "null": {"alpha", "replicas", STATISTIC: {"centre",
                  "bound"}}, "noise", "instrument", "drive", "instrument_change",
                  "unexplained", "localisation", "rejected_segments"}, ...],
     "rounds": [[every refined form], ...], "settings": {...}, "input": {...}}

The top-level ``baseline``, ``final``, ``noise_floor``, ``unexplained``,
``instrument`` and ``drive`` are the first record's (``records`` has them all).
``instrument`` holds the identified instrument chain: torsion amplifier or
accelerometer lag, speed-sensor lag, offset and gain (``speed_gain``: the stick
regression's ``value``, and ``used`` with ``from`` when the baseline identified it),
accelerometer gain and offset, the stick kinematics' drift. ``drive`` the drive speed
measured from the record (``level``, ``nominal`` [rad/s], ``mismatch`` [-], ``warning``,
the profile's ``knot_time`` [s] / ``knot_speed`` [rad/s], the speed steps whose duration
and shape the torsion moment chose, ``timed_steps`` (``mid``, ``duration`` [s],
``shape``: linear or raised cosine), per time block ``blocks``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TypeAlias

#: A strict-JSON value.
Json: TypeAlias = bool | int | float | str | list['Json'] | dict[str, 'Json'] | None


def _clean(obj: object) -> Json:
    """Make ``obj`` strict-JSON: NaN/inf become None, tuples lists."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    item = getattr(obj, 'item', None)
    if callable(item):  # numpy scalar
        return _clean(item())
    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    return str(obj)


def write_json(data: dict[str, object], path: str | Path) -> Path:
    """Write a report (strict JSON, indented, atomically) and return its path.

    Parameters
    ----------
    data : dict
        The report (:meth:`.pipeline.MissingPhysics.as_dict`).
    path : str or Path
        The file.

    Returns
    -------
    Path
        The file written.
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_suffix(p.suffix + '.tmp')
    tmp.write_text(json.dumps(_clean(data), indent=2, allow_nan=False) + '\n')
    tmp.replace(p)
    return p
