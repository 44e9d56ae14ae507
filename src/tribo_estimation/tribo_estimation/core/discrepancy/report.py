"""``discrepancy.json``: the report of the missing-physics workflow.

Layout (rms values are of the torsion-moment residual, measured - simulated, N m)::

    {"baseline": {"rms": ..., "params": {"mu0": ..., "mu_inf": ...}, ...},
     "added": [{"effect": NAME, "params": {...}, "units": {...},
                "rms_before": ..., "rms_after": ..., "delta_bic": ..., ...}, ...],
     "final": {"rms": ..., "params": {...}},
     "unexplained": [{"kind": ..., "where": ..., "size": ..., "frequency": ...}, ...],
     ...}

Further keys: ``noise_floor`` (N m), ``rounds`` (every candidate's score per
selection round), ``proposed_terms`` (sparse regression on the final residual),
``localisation`` (baseline and final residual statistics), ``settings``,
``instrument`` (the speed-sensor model fitted with the baseline:
``{"speed_lag_tau": {"value": s, "se": s, "unit": "s", "used": s}, "speed_offset":
{...}, "stick_samples": n}``; ``used`` is the value the models use: 0 unless the
estimate is beyond 3 standard errors)
and ``drive`` (the drive speed measured from the record: ``level``, ``nominal``
[rad/s], ``mismatch`` [-], ``mismatched`` (> 5 %), ``warning``, the profile's
``knot_time`` [s] / ``knot_speed`` [rad/s] and per time block ``blocks``:
``[{"block", "t_start", "t_end", "w0"}]``), ``identifiable`` (per candidate
``{"ok": bool, "reason": str, "suggest": str}``: can this record separate it from
the baseline and the instrument model, and which experiment would decide it) and
``not_identifiable`` (candidates that lowered the residual clearly but that the
record cannot separate: never named in ``added``) and ``inconsistent`` (candidates
that lowered the residual clearly as a whole but made a time block worse by more
than ``settings.max_block_loss``: they absorb a mismatch that changes during the
record; never named). Every round's candidate carries its ``block_loss`` (-).
``rejected_segments`` lists the parts of the record no segment starts in or that are
not fitted, ``[{"time": s, "reason": str}]`` (a detected stick phase in which the
shaft and chamber speeds disagree, the stick from rest before the first sliding
segment of a slip-slip record, a stick phase cut by the record start: its dwell is
unknown).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TypeAlias

from .joint import JointResult
from .select import DiscrepancyResult

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


def to_dict(result: DiscrepancyResult) -> dict[str, Json]:
    """Return the report as a strict-JSON mapping (layout: see the module docstring)."""
    d: dict[str, object] = {
        'baseline': {
            'rms': result.baseline.rms,
            'params': dict(result.baseline.params),
            'cv_rms': result.baseline.cv_rms,
        },
        'added': [
            {
                'effect': a.effect,
                'params': dict(a.params),
                'units': dict(a.units),
                'rms_before': a.rms_before,
                'rms_after': a.rms_after,
                'delta_bic': a.delta_bic,
                'cv_rms_before': a.cv_rms_before,
                'cv_rms_after': a.cv_rms_after,
                'localiser': a.localiser,
            }
            for a in result.added
        ],
        'final': {
            'rms': result.final.rms,
            'params': dict(result.final.params),
            'cv_rms': result.final.cv_rms,
        },
        'unexplained': [u.as_dict() for u in result.unexplained],
        'noise_floor': result.noise_floor,
        'rounds': [[s.as_dict() for s in rnd] for rnd in result.rounds],
        'proposed_terms': [
            {'term': t.name, 'coefficient': t.coefficient, 'contribution_rms': t.contribution_rms}
            for t in result.proposed_terms
        ],
        'localisation': {
            'baseline': result.localisation_before,
            'final': result.localisation_after,
        },
        'settings': dict(result.settings),
        'instrument': dict(result.instrument),
        'drive': dict(result.drive),
        'identifiable': {n: v.as_dict() for n, v in result.identifiable.items()},
        'not_identifiable': list(result.blocked),
        'inconsistent': list(result.inconsistent),
        'rejected_segments': [
            {'time': t, 'reason': why} for t, why in result.traces.problem.segments.rejected
        ],
    }
    return {k: _clean(v) for k, v in d.items()}


def write_json(result: DiscrepancyResult | JointResult, path: str | Path) -> Path:
    """Write ``discrepancy.json`` (strict JSON, indented) and return its path.

    A joint run of several records is written in the layout of
    :meth:`.joint.JointResult.as_dict`.
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_suffix(p.suffix + '.tmp')
    d = _clean(result.as_dict()) if isinstance(result, JointResult) else to_dict(result)
    tmp.write_text(json.dumps(d, indent=2, allow_nan=False) + '\n')
    tmp.replace(p)
    return p
