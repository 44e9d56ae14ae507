"""The Python API of tribo_nvct: nVCT configuration and detector counts in, wear out.

Examples
--------
>>> import tribo_nvct as tn
>>> cfg = tn.load_nvct('config/nvct.yaml')  # doctest: +SKIP
>>> wear = tn.evaluate_wear(tn.read_counts('counts.csv'), cfg)  # doctest: +SKIP
>>> wear.summary()['progressive_rate_um3_per_min']  # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_nvct.core.countsio import Counts

if TYPE_CHECKING:
    from tribo_nvct.core.config import NvctConfig
    from tribo_nvct.core.counting import Dwell
    from tribo_nvct.results import WearResult

PathLike = str | os.PathLike[str]
#: Sliding-distance conventions of k_w (Equ. 10): the paper's and ASTM G133's.
CONVENTIONS = ('paper', 'astm_g133')


def load_nvct(path: PathLike, *, convention: str | None = None) -> NvctConfig:
    """Read an NVCT.yaml (nuclide, depth profile, detector, contact, oil circuit).

    Parameters
    ----------
    path : str or PathLike
        The file.
    convention : str or None
        Sliding distance for k_w: ``paper`` (stroke*f*t) or ``astm_g133``
        (2*stroke*f*t); None: the file's.

    Returns
    -------
    NvctConfig
        The validated configuration.

    Raises
    ------
    NvctConfigError
        A missing key or a value out of range (named), an unknown convention.
    DepthProfileError
        The depth profile is unreadable or physically impossible.
    """
    from tribo_nvct.core.config import config_from_dict, load_config
    from tribo_nvct.errors import NvctConfigError

    p = Path(path)
    cfg = load_config(p)
    if convention is None or convention == cfg.sliding_convention:
        return cfg
    if convention not in CONVENTIONS:
        raise NvctConfigError(
            f'unknown sliding-distance convention {convention!r} (known: {", ".join(CONVENTIONS)})'
        )
    return config_from_dict(dict(cfg.raw, sliding_distance=convention), p.parent, str(p))


def read_counts(path: PathLike, *, keep_truncated: bool = False) -> Counts:
    """Read the dwells of a counts CSV or of a bag's ``/nvct/counts``.

    Parameters
    ----------
    path : str or PathLike
        Counts CSV (``t_start,t_end,counts,live_time``; s, s, counts, s) or a bag.
    keep_truncated : bool
        A bag that ends early gives the dwells before the damage instead of raising.

    Returns
    -------
    Counts
        The validated dwells, their source and a bag's damage.

    Raises
    ------
    CountsError
        A bad file, line, message or dwell (named); ``CountsBagError`` for a
        missing file or a bag without counts, ``CountsTruncatedError`` for a bag
        that ends early.
    """
    from tribo_nvct.core.countsio import read_counts as read

    return read(Path(path), keep_truncated=keep_truncated)


def evaluate_wear(
    counts: Counts | PathLike | Sequence[Dwell],
    nvct: NvctConfig | PathLike,
    *,
    convention: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> WearResult:
    """Evaluate an nVCT test: counts to wear volume, running-in and progressive wear.

    Counts become activity (decay, background, dead time), activity becomes wear
    height and volume through the depth profile (Equ. 8-9) and the oil circuit;
    the progressive rate is the regression slope over the evaluation window, the
    wear coefficients k_w = V / (L d_s) (Equ. 10).

    Parameters
    ----------
    counts : Counts, str, PathLike or sequence of Dwell
        The dwells, or the counts CSV or bag to read them from.
    nvct : NvctConfig, str or PathLike
        The test's configuration (or its NVCT.yaml).
    convention : str or None
        Sliding distance for k_w (``paper``, ``astm_g133``; None: the config's).
    progress : callable or None
        Called with (dwells done, dwells) while evaluating.

    Returns
    -------
    WearResult
        One wear state per dwell and the evaluation.

    Raises
    ------
    NvctConfigError
        Most dwells counted far fewer counts than the configured background
        alone gives (the background or the counts are wrong), or a bad config.
    CountsError
        Bad counts (as :func:`read_counts`).
    """
    from tribo_nvct.core.streaming import WearEvaluator
    from tribo_nvct.errors import NvctConfigError
    from tribo_nvct.results import WearResult

    if isinstance(nvct, str | os.PathLike):
        cfg_file = str(nvct)
        cfg = load_nvct(nvct, convention=convention)
    else:
        cfg_file = ''
        cfg = nvct
        if convention is not None and convention != cfg.sliding_convention:
            from tribo_nvct.core.config import config_from_dict

            cfg = config_from_dict(
                dict(cfg.raw, sliding_distance=convention), Path(cfg.source).parent, cfg.source
            )
    if isinstance(counts, str | os.PathLike):
        counts = read_counts(counts)
    if isinstance(counts, Counts):
        dwells, source, truncated = list(counts.dwells), counts.source, counts.truncated
    else:
        dwells, source, truncated = list(counts), '<dwells>', ''
    ev = WearEvaluator(cfg)
    repeated = 0
    for i, d in enumerate(dwells):
        if ev.add(d) is None:
            repeated += 1
        if progress is not None and i % 50 == 0:
            progress(i + 1, len(dwells))
    below = [p for p in ev.points if 'below_background' in p.flags]
    if ev.points and 2 * len(below) > len(ev.points):
        rates = sorted(p.counts / p.live_time for p in ev.points if p.live_time > 0)
        raise NvctConfigError(
            f'{cfg_file or cfg.source}: {len(below)} of {len(ev.points)} dwells of '
            f'{Path(source).name} counted far fewer counts than the configured background '
            f'alone gives (background {cfg.background.rate:.4g} counts/s, median measured '
            f'rate {rates[len(rates) // 2] if rates else math.nan:.4g} counts/s): the '
            'background or the counts are wrong'
        )
    real = sorted(d.real_time for d in dwells)
    return WearResult(
        cfg,
        tuple(ev.points),
        ev.evaluation(),
        source,
        repeated,
        truncated,
        cfg_file,
        float(real[len(real) // 2]) if real else math.nan,
    )


__all__ = ['evaluate_wear', 'load_nvct', 'read_counts']
