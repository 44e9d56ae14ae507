"""CAN sensor emulators: frames to a python-can bus, or a serial-line (slcan) adapter on a pty."""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from tribo_drivers.core.can_protocol import ACCEL_ID, SPEED_ID, CanCodec
from tribo_drivers.errors import TransportError

from .pty import PtyPort, _EmulatorThread, _PtyEmulator


class SlcanPtyDevice(_PtyEmulator):
    """A serial-line CAN adapter (slcan/Lawicel) on a pty, bridging to a send queue.

    Handles the host commands ``O`` (open), ``C`` (close), ``Sn`` (bitrate), ``V``, ``F`` and
    empty lines (answered with CR); while open, :meth:`send` writes ``tIIILDD..`` lines.
    """

    THREAD_NAME = 'slcan-device'

    def __init__(self, port: PtyPort | None = None) -> None:
        super().__init__()
        self.port = port or PtyPort()
        self.is_open = False
        self.bitrate_code = ''
        self._buf = bytearray()

    def _run(self) -> None:
        while not self._stop.is_set():
            data = self.port.read(0.02)
            self._buf.extend(data)
            while b'\r' in self._buf:
                cmd, _, rest = bytes(self._buf).partition(b'\r')
                self._buf = bytearray(rest)
                self._command(cmd.decode('ascii', 'replace'))

    def _command(self, cmd: str) -> None:
        if cmd == 'O' or cmd == 'L':
            self.is_open = True
        elif cmd == 'C':
            self.is_open = False
        elif cmd.startswith('S') or cmd.startswith('s'):
            self.bitrate_code = cmd
        elif cmd == 'V':
            self.port.write(b'V1013\r')
            return
        self.port.write(b'\r')

    def send(self, frame_id: int, data: bytes) -> bool:
        """Send one CAN frame as an slcan line; return False if the port is closed."""
        if not self.is_open:
            return False
        return self.port.write(f't{frame_id:03X}{len(data)}{data.hex().upper()}\r'.encode())


def default_can_signal(frame_id: int, seq: int) -> dict[str, tuple[float, ...]]:
    """SI values that are a known function of the frame counter (exactly representable)."""
    if frame_id == ACCEL_ID:
        return {
            'angular_acceleration': tuple(0.25 * ((seq * 3 + k) % 4001 - 2000) for k in range(3))
        }
    if frame_id == SPEED_ID:
        return {'speed': (1e-4 * (150_000 + seq % 1000),)}
    return {
        'normal_force': (0.5 * (200 + seq % 50),),
        'oil_temperature': (273.15 + 0.01 * (4000 + seq % 100),),
    }


class CanEmulator(_EmulatorThread):
    """Sends the three sensor frame types at their rates through ``send(frame_id, data)``.

    rates: frame_id -> frames per second (default: the codec's, from the DBC); seq
    counters start at ``start_seq`` (u16 wrap).
    Ground truth: ``sent[frame_id]`` is the list of unwrapped frame counters sent.
    """

    THREAD_NAME = 'can-emulator'

    def __init__(
        self,
        codec: CanCodec,
        send: Callable[[int, bytes], object],
        rates: dict[int, float] | None = None,
        start_seq: int = 0,
        skip: set[tuple[int, int]] | None = None,
    ) -> None:
        super().__init__()
        self.codec = codec
        self.send = send
        self.rates = rates or {fid: spec.frame_rate for fid, spec in codec.specs.items()}
        self.next_seq = dict.fromkeys(self.rates, start_seq)
        self.sent: dict[int, list[int]] = {fid: [] for fid in self.rates}
        self.skip = skip or set()
        self._start_seq = start_seq

    def frame(self, frame_id: int, seq: int) -> bytes:
        """Return the encoded payload of frame ``frame_id`` with sequence number ``seq``."""
        return self.codec.encode(frame_id, seq, default_can_signal(frame_id, seq))

    def _run(self) -> None:
        t0 = time.monotonic()
        while not self._stop.is_set():
            elapsed = time.monotonic() - t0
            for fid, rate in self.rates.items():
                due = self._start_seq + math.floor(elapsed * rate)
                while self.next_seq[fid] < due:
                    seq = self.next_seq[fid]
                    self.next_seq[fid] += 1
                    if (fid, seq) in self.skip:
                        continue
                    try:
                        ok = self.send(fid, self.frame(fid, seq))
                    except TransportError:
                        ok = False
                    if ok is not False:
                        self.sent[fid].append(seq)
            self._stop.wait(0.002)
