r"""ASCII line protocol of the radiation counter (nVCT detector electronics).

Sentences are ``$<body>*<XX>`` terminated by CR LF, where XX is the two-digit upper-case hex
XOR of all characters of <body> (between ``$`` and ``*``), as in NMEA 0183.

* ``$CNT,<seq>,<t_end_ms>,<dwell_ms>,<counts>,<live_ms>*XX`` one per dwell:
  seq: dwell number (u32, +1 per dwell); t_end_ms: test time at the end of the dwell [ms];
  dwell_ms: dwell length [ms]; counts: registered counts [-]; live_ms: live time [ms]
  (<= dwell_ms, the rest is dead time).
* ``$DWELL,<ms>*XX`` (host -> counter) sets the dwell length; the counter answers
  ``$ACK,DWELL,<ms>*XX``.

Example: body ``CNT,1,1000,1000,523,998`` has checksum 0x48, giving
``$CNT,1,1000,1000,523,998*48\\r\\n``.
"""

from __future__ import annotations

from dataclasses import dataclass

from tribo_drivers.errors import ChecksumError, FrameError, ProtocolError

MAX_LINE = 256


def xor_checksum(body: str) -> int:
    """XOR of the character codes of ``body`` (the text between ``$`` and ``*``)."""
    cs = 0
    for ch in body.encode('ascii'):
        cs ^= ch
    return cs


def format_sentence(body: str) -> bytes:
    r"""Frame ``body`` as the sentence ``$body*XX\r\n`` (bytes)."""
    if '$' in body or '*' in body or '\r' in body or '\n' in body:
        raise FrameError(f'sentence body must not contain $, *, CR or LF: {body!r}')
    return f'${body}*{xor_checksum(body):02X}\r\n'.encode('ascii')


def parse_sentence(line: str | bytes) -> list[str]:
    """Validate one sentence (without or with CR LF) and return its comma-separated fields."""
    if isinstance(line, bytes | bytearray):
        try:
            text = bytes(line).decode('ascii')
        except UnicodeDecodeError as exc:
            raise FrameError(f'non-ASCII bytes in line {bytes(line)[:40]!r}') from exc
    else:
        text = line
    text = text.strip('\r\n')
    start = text.rfind('$')
    if start < 0:
        raise FrameError(f'no $ in line {text[:40]!r}')
    text = text[start:]
    star = text.rfind('*')
    if star < 0 or len(text) != star + 3:
        raise FrameError(f'missing *XX checksum in line {text[:40]!r}')
    body = text[1:star]
    try:
        given = int(text[star + 1 :], 16)
    except ValueError as exc:
        raise FrameError(f'checksum is not hex in line {text!r}') from exc
    expected = xor_checksum(body)
    if given != expected:
        raise ChecksumError(f'checksum {given:02X} != {expected:02X} in line {text!r}')
    return body.split(',')


@dataclass(frozen=True)
class CountRecord:
    """One dwell of the counter, SI: seq [-], t_end, dwell, live_time [s], counts [-]."""

    seq: int
    t_end: float
    dwell: float
    counts: int
    live_time: float

    @property
    def t_start(self) -> float:
        """Test time at the start of the dwell [s]."""
        return self.t_end - self.dwell


def _int_field(fields: list[str], i: int, name: str, line: str) -> int:
    try:
        value = int(fields[i])
    except (ValueError, IndexError) as exc:
        raise FrameError(f'field {name} is not an integer in {line!r}') from exc
    if value < 0:
        raise FrameError(f'field {name} is negative in {line!r}')
    return value


def parse_cnt(line: str | bytes) -> CountRecord:
    """Parse a ``$CNT`` sentence into a :class:`CountRecord` (ms converted to s)."""
    fields = parse_sentence(line)
    text = ','.join(fields)
    if fields[0] != 'CNT':
        raise ProtocolError(f'expected a CNT sentence, got {fields[0]!r}')
    if len(fields) != 6:
        raise FrameError(f'CNT needs 5 fields, got {len(fields) - 1} in {text!r}')
    seq = _int_field(fields, 1, 'seq', text)
    t_end_ms = _int_field(fields, 2, 't_end_ms', text)
    dwell_ms = _int_field(fields, 3, 'dwell_ms', text)
    counts = _int_field(fields, 4, 'counts', text)
    live_ms = _int_field(fields, 5, 'live_ms', text)
    if dwell_ms == 0:
        raise FrameError(f'dwell of 0 ms in {text!r}')
    if live_ms > dwell_ms:
        raise FrameError(f'live time {live_ms} ms exceeds dwell {dwell_ms} ms in {text!r}')
    if seq >= 1 << 32:
        raise FrameError(f'seq {seq} exceeds u32 in {text!r}')
    return CountRecord(seq, t_end_ms / 1000.0, dwell_ms / 1000.0, counts, live_ms / 1000.0)


def format_cnt(seq: int, t_end_ms: int, dwell_ms: int, counts: int, live_ms: int) -> bytes:
    """``$CNT`` sentence (emulators, tests)."""
    return format_sentence(f'CNT,{seq},{t_end_ms},{dwell_ms},{counts},{live_ms}')


def format_dwell(dwell_ms: int) -> bytes:
    """``$DWELL,<ms>`` command."""
    if dwell_ms <= 0:
        raise FrameError(f'dwell must be > 0 ms, got {dwell_ms}')
    return format_sentence(f'DWELL,{dwell_ms}')


def format_ack_dwell(dwell_ms: int) -> bytes:
    """Frame the counter's acknowledgement of a dwell time ``dwell_ms`` [ms]."""
    return format_sentence(f'ACK,DWELL,{dwell_ms}')


def parse_dwell(line: str | bytes) -> int:
    """Dwell [ms] of a ``$DWELL`` command."""
    fields = parse_sentence(line)
    if fields[0] != 'DWELL' or len(fields) != 2:
        raise ProtocolError(f'expected DWELL,<ms>, got {",".join(fields)!r}')
    return _int_field(fields, 1, 'dwell_ms', ','.join(fields))


def parse_ack_dwell(line: str | bytes) -> int:
    """Dwell [ms] acknowledged by an ``$ACK,DWELL,<ms>`` sentence."""
    fields = parse_sentence(line)
    if fields[:2] != ['ACK', 'DWELL'] or len(fields) != 3:
        raise ProtocolError(f'expected ACK,DWELL,<ms>, got {",".join(fields)!r}')
    return _int_field(fields, 2, 'dwell_ms', ','.join(fields))


def sentence_kind(fields: list[str]) -> str:
    """'CNT', 'ACK', 'DWELL', ... (first field)."""
    return fields[0] if fields else ''


class LineSplitter:
    """Splits a byte stream into lines (LF-terminated, CR stripped).

    Over-long runs without LF (garbage) are discarded in ``MAX_LINE`` pieces and counted in
    ``overflows`` so the splitter resynchronises on the next line ending.
    """

    def __init__(self, max_line: int = MAX_LINE) -> None:
        self._buf = bytearray()
        self.max_line = max_line
        self.overflows = 0

    def feed(self, data: bytes) -> list[bytes]:
        """Append received bytes; return the complete lines (CR LF stripped) now available."""
        self._buf.extend(data)
        lines: list[bytes] = []
        while True:
            nl = self._buf.find(b'\n')
            if nl < 0:
                break
            line = bytes(self._buf[:nl]).rstrip(b'\r')
            del self._buf[: nl + 1]
            if len(line) > self.max_line:
                self.overflows += 1
                line = line[-self.max_line :]
            lines.append(line)
        if len(self._buf) > self.max_line:
            self.overflows += 1
            del self._buf[: len(self._buf) - self.max_line]
        return lines

    def reset(self) -> None:
        """Drop a partial line (after a reconnect)."""
        self._buf.clear()
