"""The decision rules on small synthetic fits: named, cannot tell apart, partial, unexplained."""

from __future__ import annotations

import math

import pytest

from tribo_estimation.core.discrepancy.candidates import SUGGEST_SPEED
from tribo_estimation.core.discrepancy.pipeline.decide import (
    CANNOT_TELL_APART,
    NAMED,
    UNEXPLAINED,
    carried,
    decide,
    explained,
    indistinguishable,
)
from tribo_estimation.core.discrepancy.pipeline.ensemble import Fit
from tribo_estimation.core.discrepancy.pipeline.noise import ChannelNoise, NoiseModel
from tribo_estimation.core.discrepancy.pipeline.null import Adequacy, NullLaw
from tribo_estimation.core.discrepancy.pipeline.screen import FormFit, Model

NOISE = NoiseModel(ChannelNoise(0.05), ChannelNoise(2.0), ChannelNoise(0.005))
REPLICAS = (1.04, 1.05, 1.045, 1.06, 1.035, 1.05, 1.055, 1.04)
LAW = NullLaw({'torsion_moment': REPLICAS, 'speed': REPLICAS, 'blocks': REPLICAS}, 0.01)
BOUND = LAW.bound('torsion_moment')


def _model(stat: float, cost: float, forms: tuple[str, ...] = ()) -> Model:
    ad = Adequacy({'torsion_moment': stat, 'speed': 1.04, 'blocks': 1.04}, NOISE)
    return Model(forms, Fit({}, cost, 1, True, {}), (ad,))


def _fit(family: str, form: str, stat: float, bounded: tuple[str, ...] = ()) -> FormFit:
    model = _model(stat, stat**2, (form,))
    fails = tuple(f'{n}@0' for n in LAW.failing(model.adequacy[0]))
    return FormFit(family, form, model, fails, bounded)


CURRENT = _model(5.0, 25.0)


def test_one_adequate_family_is_named() -> None:
    fits = [
        _fit('frictional_lag', 'frictional_lag', 1.05),
        _fit('viscous_friction', 'viscous_friction', 3.0),
    ]
    d = decide(fits, CURRENT, [LAW], single_speed=True)
    assert d.kind == NAMED
    assert d.named is not None and d.named.family == 'frictional_lag'
    # the other family improves beyond noise: listed as a partial explanation
    assert [f.family for f in d.partial] == ['viscous_friction']


def test_two_adequate_families_cannot_be_told_apart() -> None:
    fits = [
        _fit('frictional_lag', 'frictional_lag', 1.05),
        _fit('stribeck_shape', 'stribeck_shape', 1.045),
    ]
    d = decide(fits, CURRENT, [LAW], single_speed=True)
    assert d.kind == CANNOT_TELL_APART and d.named is None
    assert {f.family for f in d.alternatives} == {'frictional_lag', 'stribeck_shape'}
    # at one drive speed the separating experiment is a second speed or a step
    assert d.experiment == SUGGEST_SPEED


def test_a_parameter_at_its_bound_is_never_a_name() -> None:
    fits = [_fit('stribeck_shape', 'stribeck_shape', 1.04, bounded=('stribeck_shape',))]
    d = decide(fits, CURRENT, [LAW], single_speed=True)
    assert d.kind == UNEXPLAINED and d.named is None
    assert 'at a bound' in d.reason


def test_partial_explanations_are_not_names() -> None:
    fits = [_fit('drive_speed_ripple', 'drive_speed_ripple', 2.0)]
    d = decide(fits, CURRENT, [LAW], single_speed=False)
    assert d.kind == UNEXPLAINED and d.named is None
    assert [f.family for f in d.alternatives] == ['drive_speed_ripple']
    # (25 - 4)/(25 - c^2) of the excess, c the null's centre
    c = LAW.centre('torsion_moment')
    assert explained(fits[0], CURRENT, [LAW]) == pytest.approx((25 - 4) / (25 - c * c))


def test_improvement_within_noise_explains_nothing() -> None:
    # a fit only inside the null law's tolerance of the current model is no improvement
    tol = LAW.tolerance('torsion_moment')
    near = 5.0 * (1.0 - 0.5 * tol)
    d = decide(
        [_fit('bearing_friction', 'bearing_friction', near)], CURRENT, [LAW], single_speed=True
    )
    assert d.kind == UNEXPLAINED and d.partial == ()


def test_indistinguishable_is_symmetric_and_bounded_by_the_tolerance() -> None:
    tol = LAW.tolerance('torsion_moment')
    a = _model(2.0, 4.0)
    b = _model(2.0 * (1.0 + 0.5 * tol), 4.0)
    c = _model(2.0 * (1.0 + 2.0 * tol), 4.0)
    assert indistinguishable(a, b, [LAW]) and indistinguishable(b, a, [LAW])
    assert not indistinguishable(a, c, [LAW])
    assert LAW.centre('torsion_moment') < BOUND


def test_a_fit_that_only_crosses_the_bound_is_no_name() -> None:
    # the current model fails just beyond the bound; a family brings it just within:
    # a change smaller than the replicas' spread (the tolerance) decides nothing
    tol = LAW.tolerance('torsion_moment')
    current = _model(BOUND * 1.01, (BOUND * 1.01) ** 2)
    inside = BOUND * 0.99
    assert 0.0 < math.log(1.01 / 0.99) < tol
    fits = [
        _fit('bearing_friction', 'bearing_friction', inside),
        _fit('torque_offset', 'torque_offset', inside),
    ]
    assert all(f.adequate for f in fits)
    d = decide(fits, current, [LAW], single_speed=True)
    assert d.kind == UNEXPLAINED and d.named is None and d.alternatives == ()
    assert 'cannot decide' in d.reason
    # the same family from far beyond the bound resolves it: named
    far = _model(BOUND * math.exp(3.0 * tol), 1.0)
    d = decide(fits[:1], far, [LAW], single_speed=True)
    assert d.kind == NAMED and d.named is not None and d.named.family == 'bearing_friction'


def test_a_form_kept_tentatively_stays_the_answer_when_nothing_lowers_the_rest() -> None:
    # round 1 kept viscous friction (5.0 -> 1.8, failing); round 2 finds nothing: the
    # answer is round 1's partial explanation with its share (25 - 3.24)/(25 - c^2)
    kept = _fit('viscous_friction', 'viscous_friction', 1.8)
    round2 = decide([_fit('stribeck_shape', 'stribeck_shape', 1.799)], kept.model, [LAW],
                    single_speed=False)  # fmt: skip
    assert round2.kind == UNEXPLAINED and not round2.partial
    d = carried(round2, [(kept, CURRENT)], [LAW])
    assert d.kind == UNEXPLAINED and d.named is None
    assert [f.family for f in d.alternatives] == ['viscous_friction']
    assert [f.family for f in d.partial] == ['viscous_friction']
    c = LAW.centre('torsion_moment')
    share = (25.0 - 1.8**2) / (25.0 - c * c)
    assert f'viscous_friction explains {100 * share:.0f} % of the excess' in d.reason
    assert round2.reason in d.reason
    # a round with its own answer is left as it is
    named = decide([_fit('frictional_lag', 'frictional_lag', 1.05)], kept.model, [LAW],
                   single_speed=False)  # fmt: skip
    assert carried(named, [(kept, CURRENT)], [LAW]) is named
