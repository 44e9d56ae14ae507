"""The one YAML loader (tribo_common.yamlio): YAML 1.2 floats, duplicate and unknown keys."""

from __future__ import annotations

import pytest


def test_yaml_12_floats_duplicates_and_unknown_keys() -> None:
    from tribo_common.yamlio import check_keys, parse_yaml

    data = parse_yaml('a: 1e5\nb: 2.0e6\nc: -3E-2\nd: 7\ne: 1.5\n', 's', ValueError)
    assert data == {'a': 1e5, 'b': 2e6, 'c': -0.03, 'd': 7, 'e': 1.5}
    assert isinstance(data['d'], int)
    with pytest.raises(ValueError, match=r"duplicate key 'k' on line 3 \(first on line 1\)"):
        parse_yaml('k: 1\nx: 2\nk: 3\n', 's', ValueError)
    with pytest.raises(ValueError, match=r"unknown key 'k_det_rel_sd' .did you mean 'k_det_rel_se"):
        check_keys({'k_det_rel_sd': 1}, ('k_det', 'k_det_rel_se'), 's', ValueError)
