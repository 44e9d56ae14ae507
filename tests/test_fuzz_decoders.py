"""Property-based suite of the driver decoders on garbage bytes (hypothesis).

Every decoder fed arbitrary bytes (pure garbage, valid frames with flipped bits,
cuts, frames split across chunks) either returns well-formed values or raises
one of the package's :class:`~tribo_drivers.errors.DriverError` subclasses
with a one-line message; never another exception, never a hang, never a
non-finite value. Profiles as in ``test_fuzz_commands.py``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from support import ROOT

from tribo_drivers.core import counter_protocol as cp
from tribo_drivers.core import daq_protocol as dp
from tribo_drivers.errors import DriverError

#: Decoders are cheap: more examples than the commands in each profile.
MANY = settings(max_examples=min(settings.default.max_examples * 50, 20_000))


def _one_line(exc: DriverError) -> None:
    text = str(exc)
    assert text.strip() and '\n' not in text.strip(), repr(text)


def _valid_daq(n: int) -> bytes:
    idx = np.arange(n, dtype=np.int64)
    return dp.encode_frames(
        idx, np.linspace(-5e7, 5e7, n), np.linspace(-5e6, 5e6, n), np.full(n, 31416)
    )


@MANY
@given(
    frames=st.integers(0, 20),
    flips=st.lists(st.tuples(st.floats(0, 1), st.integers(0, 255)), max_size=8),
    garbage=st.binary(max_size=200),
    split=st.lists(st.floats(0, 1), max_size=4),
)
def test_daq_decoder_on_garbage(
    frames: int, flips: list[tuple[float, int]], garbage: bytes, split: list[float]
) -> None:
    data = bytearray(_valid_daq(frames) + garbage)
    for pos, val in flips:
        if data:
            data[min(len(data) - 1, int(pos * len(data)))] = val
    cuts = sorted({0, len(data), *(int(s * len(data)) for s in split)})
    dec = dp.DaqDecoder()
    total = 0
    for a, b in itertools.pairwise(cuts):
        try:
            out = dec.feed(bytes(data[a:b]))
        except DriverError as exc:
            _one_line(exc)
            continue
        total += len(out)
        for arr in (out.torsion_moment, out.angular_acceleration, out.speed):
            assert np.all(np.isfinite(arr))
    assert total <= len(data) // dp.FRAME_SIZE


@MANY
@given(line=st.one_of(st.binary(max_size=300), st.text(max_size=120).map(str.encode)))
def test_counter_sentences_on_garbage(line: bytes) -> None:
    for parse in (cp.parse_sentence, cp.parse_cnt, cp.parse_dwell, cp.parse_ack_dwell):
        try:
            parse(line)
        except DriverError as exc:
            _one_line(exc)


@MANY
@given(
    seq=st.integers(0, 2**32),
    fields=st.lists(st.integers(-(2**40), 2**40), min_size=4, max_size=4),
    flip=st.one_of(st.none(), st.tuples(st.floats(0, 1), st.integers(0, 255))),
)
def test_counter_records_on_bad_values(
    seq: int, fields: list[int], flip: tuple[float, int] | None
) -> None:
    try:
        raw = bytearray(cp.format_cnt(seq, *fields))
    except DriverError as exc:
        _one_line(exc)
        return
    if flip is not None:
        raw[min(len(raw) - 1, int(flip[0] * len(raw)))] = flip[1]
    try:
        rec = cp.parse_cnt(bytes(raw))
    except DriverError as exc:
        _one_line(exc)
        return
    assert rec.counts >= 0 and rec.live_time >= 0.0 and math.isfinite(rec.t_end)


@MANY
@given(chunks=st.lists(st.binary(max_size=400), max_size=6))
def test_line_splitter_bounded(chunks: list[bytes]) -> None:
    sp = cp.LineSplitter()
    for c in chunks:
        try:
            lines = sp.feed(c)
        except DriverError as exc:
            _one_line(exc)
            continue
        assert all(len(ln) <= cp.MAX_LINE + 2 for ln in lines)


_CODEC = None


def _codec():  # type: ignore[no-untyped-def]
    global _CODEC
    if _CODEC is None:
        import cantools.database  # noqa: F401  (loaded whole, even after an interrupted run)

        from tribo_drivers.core.can_protocol import CanCodec

        _CODEC = CanCodec(ROOT / 'config' / 'tribo.dbc')
    return _CODEC


@MANY
@given(frame_id=st.integers(0, 0x7FF), data=st.binary(max_size=12))
def test_can_decoder_on_garbage(frame_id: int, data: bytes) -> None:
    codec = _codec()
    ids = sorted(codec.specs)
    for fid in (frame_id, ids[frame_id % len(ids)]):
        try:
            s = codec.decode(fid, data)
        except DriverError as exc:
            _one_line(exc)
            continue
        if s is not None:
            assert all(math.isfinite(v) for vals in s.values.values() for v in vals)
