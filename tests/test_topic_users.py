"""Every user of topic names takes them from the one topic table (tribo_common.topics): no
topic literal elsewhere in the nodes, the bag I/O or the bridge."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tribo_common import topics

ROOT = Path(__file__).resolve().parents[1]


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
