"""The one topic table (tribo_common.topics): relative names, resolution in a namespace."""

from __future__ import annotations

import pytest

from tribo_common import topics


def test_names_are_relative_except_diagnostics() -> None:
    for t in topics.TOPICS:
        assert t.name.startswith('/') == (t is topics.DIAGNOSTICS), t.name
        assert t.description and t.rate >= 0.0


@pytest.mark.parametrize(
    ('namespace', 'want'),
    [('', '/rig/speed'), ('/', '/rig/speed'), ('rigB', '/rigB/rig/speed'),
     ('/rigB/', '/rigB/rig/speed'), ('/lab/rigB', '/lab/rigB/rig/speed')],
)  # fmt: skip
def test_resolve_and_split(namespace: str, want: str) -> None:
    assert topics.SPEED.resolve(namespace) == want
    assert topics.split(want) == (topics.normalize_namespace(namespace), topics.SPEED)
    assert topics.DIAGNOSTICS.resolve(namespace) == '/diagnostics'
    assert topics.split('/rigB/rig/unknown') is None
