"""Streaming nVCT evaluator: one dwell at a time, state saved to / restored from JSON.

The state is the list of accepted dwells (raw counts; everything else is
recomputed from them and the configuration), so a restored evaluator is
identical to the one that never stopped. The configuration's fingerprint is
stored with the state; a state from another configuration is refused.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from tribo_nvct.core.config import NvctConfig
from tribo_nvct.core.counting import Dwell, check_sequence, counts_to_activity
from tribo_nvct.core.evaluation import Evaluation, evaluate, recent_rate
from tribo_nvct.core.wear import WearPoint, make_point
from tribo_nvct.errors import CountsError, NonMonotonicTimeError, StateError

STATE_VERSION = 1


@dataclass(frozen=True)
class RateEstimate:
    """Current wear rate [m^3/s] and its standard error."""

    rate: float
    se: float


class WearEvaluator:
    """Turn dwells into :class:`WearPoint` s and evaluate them (paper 3.5).

    rate_window_s: span of the recent-rate regression [s].
    """

    def __init__(self, cfg: NvctConfig, rate_window_s: float = 600.0) -> None:
        if not (math.isfinite(rate_window_s) and rate_window_s > 0.0):
            raise StateError(f'rate window must be > 0 s, got {rate_window_s!r}')
        self.cfg = cfg
        self.rate_window_s = float(rate_window_s)
        self._dwells: list[Dwell] = []
        self._seqs: list[int | None] = []
        self._points: list[WearPoint] = []
        # Deposition rebuild: running sum of A_det*dt and of its variance weight.
        self._dep_sum = 0.0
        self._dep_var = 0.0

    @property
    def points(self) -> list[WearPoint]:
        """Wear points so far (copy)."""
        return list(self._points)

    @property
    def dwells(self) -> list[Dwell]:
        """Accepted dwells (copy)."""
        return list(self._dwells)

    def add(self, dwell: Dwell, seq: int | None = None) -> WearPoint | None:
        """Process one dwell; returns its wear point, or None for an exact repeat.

        A repeat of the last dwell (same times and counts, e.g. replayed after a
        restart) is ignored; any other dwell that goes back in time raises
        :class:`NonMonotonicTimeError` and leaves the state unchanged.
        """
        prev = self._dwells[-1] if self._dwells else None
        if prev is not None and dwell.t_end <= prev.t_end:
            if any(d == dwell for d in self._dwells[-50:]):
                return None
            raise NonMonotonicTimeError(
                f'dwell {dwell.t_start:g}-{dwell.t_end:g} s goes back in time '
                f'(last accepted ends at {prev.t_end:g} s)'
            )
        gap = check_sequence(prev, dwell)
        last_seq = self._seqs[-1] if self._seqs else None
        if seq is not None and last_seq is not None and seq != last_seq + 1:
            gap = True  # a sequence jump is a lost dwell
        cfg = self.cfg
        act = counts_to_activity(
            dwell, cfg.background, cfg.k_det, cfg.decay_constant, cfg.reference_offset_s
        )
        released, released_se = act.activity, act.se
        k_dep = cfg.circuit.deposition_rate if cfg.circuit is not None else 0.0
        dep_sum, dep_var = self._dep_sum, self._dep_var
        if k_dep > 0.0:
            dt = dwell.t_end - (prev.t_end if prev is not None else 0.0)
            released = act.activity * (1.0 + k_dep * dt) + k_dep * dep_sum
            released_se = math.sqrt((1.0 + k_dep * dt) ** 2 * act.se**2 + k_dep**2 * dep_var)
            dep_sum += act.activity * dt
            dep_var += (act.se * dt) ** 2
        point = make_point(cfg, dwell, act, released, released_se, gap)
        self._dep_sum, self._dep_var = dep_sum, dep_var
        self._dwells.append(dwell)
        self._seqs.append(seq)
        self._points.append(point)
        return point

    def evaluation(self, fit_model: bool = True, profile_se: bool = True) -> Evaluation:
        """Running-in/progressive evaluation of the points so far (model fit optional).

        profile_se: also the depth-profile/k_DET standard errors; the profile's
        bootstrap is computed once per configuration (first call) and cached.
        """
        return evaluate(self._points, self.cfg, fit_model, profile_se)

    def current_rate(self) -> RateEstimate:
        """Wear rate over the last ``rate_window_s`` [m^3/s]."""
        r, se = recent_rate(self._points, self.rate_window_s)
        return RateEstimate(r, se)

    # --- persistence -------------------------------------------------------
    def state_dict(self) -> dict[str, object]:
        """JSON-ready state (version, config fingerprint, dwells)."""
        return {
            'version': STATE_VERSION,
            'config_fingerprint': self.cfg.fingerprint,
            'config_source': self.cfg.source,
            'rate_window_s': self.rate_window_s,
            'dwells': [
                [d.t_start, d.t_end, d.counts, d.live_time, s]
                for d, s in zip(self._dwells, self._seqs, strict=True)
            ],
        }

    def save(self, path: str | Path) -> None:
        """Write the state atomically (temp file + rename) to ``path``."""
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=p.name + '.', suffix='.tmp', dir=p.parent)
        try:
            with os.fdopen(fd, 'w', encoding='utf-8') as fh:
                json.dump(self.state_dict(), fh)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, p)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

    @classmethod
    def from_state_dict(cls, cfg: NvctConfig, state: dict[str, object]) -> WearEvaluator:
        """Rebuild an evaluator by replaying the saved dwells."""
        if not isinstance(state, dict) or state.get('version') != STATE_VERSION:
            raise StateError(f'unsupported evaluator state (version {state.get("version")!r})')
        if state.get('config_fingerprint') != cfg.fingerprint:
            raise StateError(
                f'saved state belongs to another configuration ({state.get("config_source")!r}, '
                f'fingerprint {state.get("config_fingerprint")!r} != {cfg.fingerprint!r})'
            )
        window = state.get('rate_window_s', 600.0)
        if isinstance(window, bool) or not isinstance(window, int | float | str):
            raise StateError(f'saved state: rate_window_s is not a number: {window!r}')
        ev = cls(cfg, float(window))
        rows = state.get('dwells')
        if not isinstance(rows, list):
            raise StateError('saved state has no dwell list')
        for i, row in enumerate(rows):
            try:
                t0, t1, c, lt, s = row
                ev.add(
                    Dwell(float(t0), float(t1), int(c), float(lt)), None if s is None else int(s)
                )
            except (TypeError, ValueError, CountsError) as exc:
                raise StateError(f'saved state: dwell {i} is corrupt ({exc})') from None
        return ev

    @classmethod
    def load(cls, cfg: NvctConfig, path: str | Path) -> WearEvaluator:
        """Read a state file written by :meth:`save`."""
        p = Path(path)
        try:
            state = json.loads(p.read_text(encoding='utf-8'))
        except OSError as exc:
            raise StateError(f'cannot read state {p}: {exc.strerror}') from None
        except json.JSONDecodeError as exc:
            raise StateError(
                f'state {p} is not valid JSON ({exc.msg} at line {exc.lineno})'
            ) from None
        return cls.from_state_dict(cfg, state)
