"""A fitted parameter at the bound of its box (pipeline/ensemble.py)."""

from __future__ import annotations

import pytest

from tribo_estimation.core.discrepancy import candidates as cand_lib
from tribo_estimation.core.discrepancy.pipeline.ensemble import at_bound


@pytest.mark.parametrize(
    ('form', 'values'),
    [
        # a 5 Hz ripple: 1 % of the box (0.05-2000 Hz) counted linearly is 20 Hz, which
        # called every ripple under 20 Hz a form mismatch; counted in log it is 11 %
        ('drive_speed_ripple', {'ripple_amp': 0.05, 'ripple_freq': 5.0, 'ripple_phase': 0.3}),
        # 4 per revolution (box 0.2-500): 1 % linearly is 5 per revolution
        ('drive_speed_ripple_angle',
         {'ripple_rel': 0.01, 'ripple_order': 4.0, 'ripple_angle_phase': 0.2}),
    ],
)  # fmt: skip
def test_a_low_frequency_or_order_is_not_at_its_bound(form: str, values: dict[str, float]) -> None:
    assert at_bound(cand_lib.get(form).params, values, 0.01) == []


def test_a_frequency_at_its_lower_bound_is() -> None:
    # 0.051 Hz is within 1 % (in log) of the box's 0.05 Hz
    values = {'ripple_amp': 0.05, 'ripple_freq': 0.051, 'ripple_phase': 0.3}
    assert at_bound(cand_lib.get('drive_speed_ripple').params, values, 0.01) == ['ripple_freq']
