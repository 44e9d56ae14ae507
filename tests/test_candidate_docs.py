"""The candidate table of docs/physics.md (section 8) is the registry's, and each
candidate is one registration (its equation, suggestion and measurement hook).

Regenerate the table with ``python -m tribo_bringup.paramdocs --physics docs/physics.md``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tribo_bringup.paramdocs import CANDIDATES_BEGIN, CANDIDATES_END, render_physics
from tribo_estimation.core import measurement
from tribo_estimation.core.discrepancy import candidates
from tribo_estimation.core.discrepancy.pipeline.decide import experiment
from tribo_estimation.core.model import Extensions

ROOT = Path(__file__).resolve().parents[1]


def test_physics_candidate_table_is_current() -> None:
    doc = (ROOT / 'docs' / 'physics.md').read_text(encoding='utf-8')
    assert CANDIDATES_BEGIN in doc and CANDIDATES_END in doc
    assert doc == render_physics(doc), (
        'run: python -m tribo_bringup.paramdocs --physics docs/physics.md'
    )
    table = doc.split(CANDIDATES_BEGIN)[1].split(CANDIDATES_END)[0]
    # one row per registered candidate, the new stribeck_shape among them
    for c in candidates.all_candidates():
        assert f'| `{c.name}`' in table, c.name
        for p in c.params:
            assert f'`{p.name}` [{p.unit}]' in table, p.name
    assert '| `stribeck_shape` |' in table


def test_every_candidate_has_its_equation_and_suggestion() -> None:
    for c in candidates.all_candidates():
        assert c.equation, f'{c.name}: no equation text'
        # each form belongs to a family, and its family lists it
        assert c in candidates.forms(c.family_name), c.name
    for fam in candidates.families():
        wanted = {f.suggest for f in candidates.forms(fam)}
        # the experiment the pipeline suggests for a family is one of its forms' suggestions
        assert experiment([fam], single_speed=False) in wanted, fam
        # a form that wants a second speed decides the experiment of a one-speed record
        if candidates.SUGGEST_SPEED in wanted:
            assert experiment([fam], single_speed=True) == candidates.SUGGEST_SPEED, fam
    # a family of one form: the pipeline's experiment is that form's registered suggestion
    (viscous,) = candidates.forms('viscous_friction')
    assert experiment(['viscous_friction'], single_speed=False) == viscous.suggest


def test_measurement_fields_come_from_the_effects() -> None:
    from tribo_estimation.core.discrepancy import fitting

    fields = measurement.measurement_fields()
    assert fields == {
        'torque_offset', 'torque_offset_drift', 'torque_lag_tau', 'torque_thermal',
        'torque_thermal_tau',
    }  # fmt: skip
    # the fit's hand-written list agrees with the registered hooks
    assert fields == fitting.MEASUREMENT_FIELDS
    kinds = {c.name for c in candidates.all_candidates() if c.measurement is not None}
    assert kinds == {'torque_offset', 'torque_sensor_lag'}
    # the thermal form has no hook of its own: its fields go through its family's
    fitted = {p.name for c in candidates.forms('torque_offset') for p in c.params}
    assert {'torque_thermal', 'torque_thermal_tau'} <= fitted


def test_measurement_transforms_round_trip_at_segment_starts() -> None:
    # a ramp M_t = 2 + 30*t through the lag and offset: the segment-start inversion
    # recovers the true value within the discretisation of the lag (exact for a ramp)
    dt = 1e-4
    t = np.arange(2000) * dt
    x = 2.0 + 30.0 * t
    ext = Extensions(torque_lag_tau=2e-3, torque_offset=0.5, torque_offset_drift=0.1)
    y, state = measurement.apply_measurement_transforms(ext, t, x, dt, state=float('nan'))
    # the carried state is the lag's output, before the offset [N m]
    assert abs(state - (y[-1] - 0.5 - 0.1 * t[-1])) < 1e-12
    i = np.array([1500])
    slope = np.array([(y[1501] - y[1499]) / (2 * dt)])
    true = measurement.true_torsion_at_starts(ext, t[i], y[i], slope, dt)
    # settled ramp (75 lag time constants): the lag is exactly dt*a/(1-a)*slope [N m]
    assert abs(true[0] - x[1500]) < 1e-9
    # started from the measured value, the first output of each segment equals it
    seg = (np.array([0, 1000]), np.array([1000, 2000]))
    y2, _ = measurement.apply_measurement_transforms(
        ext, t, x, dt, segments=seg, measured_first=y[seg[0]]
    )
    np.testing.assert_allclose(y2[seg[0]], y[seg[0]], rtol=0, atol=1e-12)
