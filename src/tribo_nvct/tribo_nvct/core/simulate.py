"""Forward simulator of an nVCT test.

True wear -> released activity -> oil circuit -> detector counts (Poisson,
background, decay, non-paralysable dead time).

Used by the tests, the benchmark, ``tribo wear --simulate`` and the simulated
detector node. The true wear curve is the running-in + progressive model of
paper 3.5:  V(t) = V_r (1 - exp(-t/tau)) + w t  [m^3].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from tribo_common.yamlio import load_yaml
from tribo_nvct.core.config import NvctConfig, load_config
from tribo_nvct.core.counting import Dwell
from tribo_nvct.core.profile import DepthProfile
from tribo_nvct.errors import NvctConfigError

FloatArray = NDArray[np.float64]
UM3 = 1e-18


@dataclass(frozen=True)
class TrueWear:
    """True wear: running-in volume V_r [m^3], time constant tau [s], progressive rate w [m^3/s]."""

    running_in_volume: float
    tau: float
    progressive_rate: float

    def __post_init__(self) -> None:
        """Refuse a negative running-in volume [m^3] or rate [m^3/s], or tau [s] <= 0."""
        if not (self.running_in_volume >= 0.0 and self.tau > 0.0 and self.progressive_rate >= 0.0):
            raise NvctConfigError(
                'true wear needs running_in_volume >= 0, tau > 0, progressive_rate >= 0'
            )

    def volume(self, t: FloatArray | float) -> FloatArray:
        """V_W(t) [m^3] at test time t [s] (0 before the start)."""
        tt = np.clip(np.asarray(t, dtype=float), 0.0, None)
        return np.asarray(
            self.running_in_volume * -np.expm1(-tt / self.tau) + self.progressive_rate * tt
        )


@dataclass(frozen=True)
class SimSettings:
    """Test schedule: duration [s], dwell [s], dead time per count [s], pause between dwells [s]."""

    duration: float = 240 * 60.0
    dwell: float = 60.0
    dead_time: float = 5e-6
    pause: float = 0.0

    def __post_init__(self) -> None:
        """Refuse a duration or dwell [s] <= 0, or a negative dead time or pause [s]."""
        if not (self.duration > 0 and self.dwell > 0 and self.dead_time >= 0 and self.pause >= 0):
            raise NvctConfigError('simulation needs duration > 0, dwell > 0, dead_time/pause >= 0')


class ForwardSimulator:
    """Expected and random detector counts of a simulated test.

    cfg: nVCT configuration (k_DET, background, decay, areas, circuit);
    truth: true wear curve; settings: schedule; profile: true depth profile
    (default: the configuration's fitted profile, so the evaluation has no
    profile error). Wear beyond the profile releases no further activity.
    """

    def __init__(
        self,
        cfg: NvctConfig,
        truth: TrueWear,
        settings: SimSettings | None = None,
        profile: DepthProfile | None = None,
        grid_step: float = 1.0,
    ) -> None:
        self.cfg = cfg
        self.truth = truth
        self.settings = settings or SimSettings()
        self.profile = profile or cfg.profile
        s = self.settings
        starts = np.arange(0.0, s.duration - s.dwell + 1e-9, s.dwell + s.pause)
        self.t_start = starts
        self.t_end = starts + s.dwell
        # Fine grid for the release history and the circuit convolution.
        n = math.ceil(s.duration / grid_step) + 1
        tg: FloatArray = np.arange(n, dtype=float) * grid_step
        self.grid = tg
        h = truth.volume(tg) / cfg.contact_area
        F = np.interp(h, self.profile.z_grid, self.profile.cumulative)  # saturates at max depth
        released = cfg.tagged_area * F  # [Bq] at the reference date
        if cfg.circuit is not None:
            seen = cfg.circuit.detector_activity(tg, released)
        else:
            seen = released
        lam = cfg.decay_constant
        # seen [Bq] at the reference date -> count rate [1/s]
        rate = seen * np.exp(-lam * (cfg.reference_offset_s + tg)) / cfg.k_det
        # Expected true (dead-time free) counts per dwell: integral of rate + background.
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(tg))])
        sig = np.interp(self.t_end, tg, cum) - np.interp(self.t_start, tg, cum)
        self.expected_true_counts = sig + cfg.background.rate * s.dwell

    def true_volume(self, t: FloatArray | float) -> FloatArray:
        """Return the true wear volume [m^3] at time ``t`` [s]."""
        return self.truth.volume(t)

    def dwell(self, i: int, rng: np.random.Generator) -> Dwell:
        """Random counts of dwell i (non-paralysable dead time, Poisson)."""
        s = self.settings
        mu = float(self.expected_true_counts[i])
        n_true = mu / s.dwell
        registered_rate = n_true / (1.0 + n_true * s.dead_time)
        counts = int(rng.poisson(registered_rate * s.dwell))
        live = s.dwell - counts * s.dead_time
        return Dwell(float(self.t_start[i]), float(self.t_end[i]), counts, live)

    def run(self, seed: int | None = None) -> list[Dwell]:
        """All dwells of the test with a seeded generator."""
        rng = np.random.default_rng(seed)
        return [self.dwell(i, rng) for i in range(self.t_start.size)]

    def paper_truth(self) -> dict[str, float]:
        """Paper 3.5 quantities of the noise-free true curve (window regression) [SI]."""
        t1, t2 = self.cfg.window_s
        tt = np.linspace(t1, t2, 601)
        vv = self.truth.volume(tt)
        b, a = np.polyfit(tt, vv, 1)
        return {
            'total_volume': float(self.truth.volume(t2)),
            'progressive_rate': float(b),
            'progressive_volume': float(b * t2),
            'running_in_volume': float(self.truth.volume(t2) - b * t2),
            'window_intercept': float(a),
        }


def write_counts_csv(path: str | Path, dwells: list[Dwell], header: str = '') -> None:
    """Write ``t_start,t_end,counts,live_time`` (s, s, counts, s)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    lines = [f'# {ln}' for ln in header.splitlines() if ln]
    lines.append('t_start,t_end,counts,live_time')
    lines += [f'{d.t_start:.6f},{d.t_end:.6f},{d.counts:d},{d.live_time:.9f}' for d in dwells]
    Path(path).write_text('\n'.join(lines) + '\n', encoding='utf-8')


@dataclass(frozen=True, eq=False)
class SimDetectorConfig:
    """sim_detector.yaml: truth, schedule, accelerated clock and the nVCT configuration."""

    nvct: NvctConfig
    truth: TrueWear
    settings: SimSettings
    time_scale: float
    seed: int | None


#: Most dwells a simulated test may have (a 4 h test of 60 s dwells has 240).
MAX_DWELLS = 1e6


def _pos(d: dict[str, object], key: str, src: str, default: float | None = None) -> float:
    v = d.get(key, default)
    if v is None:
        raise NvctConfigError(f'{src}: missing key {key!r}')
    if isinstance(v, str):
        try:
            v = float(v)  # YAML 1.1 reads 2.5e5 as a string
        except ValueError:
            raise NvctConfigError(f'{src}: {key} must be a number, got {v!r}') from None
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
        raise NvctConfigError(f'{src}: {key} must be a finite number >= 0, got {v!r}')
    return float(v)


def load_sim_config(path: str | Path, nvct_override: str | Path | None = None) -> SimDetectorConfig:
    """Read sim_detector.yaml (``nvct_config`` relative to it unless overridden)."""
    p = Path(path)
    src = str(p)
    raw = load_yaml(p, NvctConfigError, 'simulated-detector config')
    if not isinstance(raw, dict):
        raise NvctConfigError(f'{src}: top level must be a mapping')
    if nvct_override is not None:
        nvct_path = Path(nvct_override)
    else:
        if 'nvct_config' not in raw:
            raise NvctConfigError(f'{src}: missing key nvct_config')
        nvct_path = Path(str(raw['nvct_config']))
        if not nvct_path.is_absolute():
            nvct_path = p.parent / nvct_path
    cfg = load_config(nvct_path)
    tw = raw.get('true_wear')
    if not isinstance(tw, dict):
        raise NvctConfigError(f'{src}: missing mapping true_wear')
    truth = TrueWear(
        running_in_volume=_pos(tw, 'running_in_volume_um3', src) * UM3,
        tau=_pos(tw, 'running_in_tau_min', src) * 60.0,
        progressive_rate=_pos(tw, 'progressive_rate_um3_per_min', src) * UM3 / 60.0,
    )
    settings = SimSettings(
        duration=_pos(raw, 'duration_min', src, 240.0) * 60.0,
        dwell=_pos(raw, 'dwell_s', src, 60.0),
        dead_time=_pos(raw, 'dead_time_s', src, 5e-6),
        pause=_pos(raw, 'pause_s', src, 0.0),
    )
    if not (settings.dwell > 0.0 and settings.duration / settings.dwell <= MAX_DWELLS):
        raise NvctConfigError(
            f'{src}: duration_min / dwell_s must give at most {MAX_DWELLS:g} dwells '
            f'(dwell_s > 0), got duration {settings.duration:g} s, dwell {settings.dwell:g} s'
        )
    scale = _pos(raw, 'time_scale', src, 240.0)
    if scale <= 0:
        raise NvctConfigError(f'{src}: time_scale must be > 0')
    seed = raw.get('seed')
    if seed is not None and not isinstance(seed, int):
        raise NvctConfigError(f'{src}: seed must be an integer or null, got {seed!r}')
    return SimDetectorConfig(cfg, truth, settings, scale, seed)
