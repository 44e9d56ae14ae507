"""Form ``friction_drift_saturating`` of the family ``friction_drift``.

mu0 and mu_inf approach new levels exponentially with test time (running-in,
warming up): ``mu0(t) = mu0 + D0*(1 - exp(-t/tau))``, ``mu_inf(t) = mu_inf +
D_inf*(1 - exp(-t/tau))`` (D0, D_inf [-], tau [s], t the record's time). Applied per
shooting segment (:attr:`..candidates.Candidate.levels`): within a segment the
levels follow their tangent at its start (the kernel's linear drift).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..candidates import SUGGEST_LONGER, Candidate, ParamSpec, register
from ..stats import FloatArray


def _levels(
    values: Mapping[str, float], t: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return the changes of mu0, mu_inf [-] and their rates [1/s] at times ``t`` [s]."""
    tau = max(float(values.get('drift_sat_tau', 1.0)), 1e-9)
    e = np.exp(-np.maximum(t, 0.0) / tau)
    d0 = float(values.get('drift_sat_mu0', 0.0))
    di = float(values.get('drift_sat_mu_inf', 0.0))
    return d0 * (1.0 - e), d0 / tau * e, di * (1.0 - e), di / tau * e


CANDIDATE = register(
    Candidate(
        'friction_drift_saturating',
        'mu0 and mu_inf approach new levels exponentially with test time (running-in, '
        'warming): mu(t) = mu + D*(1 - exp(-t/tau))',
        (
            ParamSpec('drift_sat_mu0', '-', -0.5, 0.5, 0.01, 0.0),
            ParamSpec('drift_sat_mu_inf', '-', -0.5, 0.5, 0.01, 0.0),
            ParamSpec('drift_sat_tau', 's', 0.05, 1e3, 1.0, 2.0, log=True),
        ),
        'test_time',
        lambda _ctx: [{'drift_sat_tau': tau} for tau in (0.3, 1.0, 3.0, 10.0)],
        equation=(
            '`mu0(t) = mu0 + D0*(1 - exp(-t/tau))`, `mu_inf(t) = mu_inf + D_inf*(1 - '
            'exp(-t/tau))` (D0, D_inf, tau = `drift_sat_mu0`, `drift_sat_mu_inf`, '
            '`drift_sat_tau`; per segment, the tangent at its start)'
        ),
        suggest=SUGGEST_LONGER,
        profile='drift_sat_tau',
        family='friction_drift',
        levels=_levels,
    )
)
