"""The one topic table (tribo_common.topics): relative names, and every user takes its
names from it (no topic literal elsewhere in the nodes, the bag I/O or the bridge)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tribo_common import topics

ROOT = Path(__file__).resolve().parents[1]


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


def test_bagio_and_qos_derive_from_the_table() -> None:
    pytest.importorskip('rosbags')
    from tribo_bringup import bagio

    assert {t.resolve(): t.msgtype for t in topics.TOPICS} == bagio.TOPIC_TYPES
    assert tuple(t.resolve() for t in topics.RIG_STREAMS) == bagio.RIG_TOPICS


def test_no_topic_literals_outside_the_table() -> None:
    files = [
        *ROOT.glob('src/*/tribo_*/nodes/*.py'),
        *(ROOT / 'src/tribo_bringup/tribo_bringup' / n
          for n in ('bagio.py', 'recorder.py', 'bridge_core.py', 'graph.py')),
        *ROOT.glob('src/tribo_bringup/launch/*.py'),
    ]  # fmt: skip
    literal = re.compile(r"""['"]/?(rig|nvct|friction)/[a-z_]+['"]|['"]/diagnostics['"]""")
    found = [f'{f.name}: {m.group(0)}' for f in files for m in literal.finditer(f.read_text())]
    assert not found, found
