"""DAQ driver benchmarks: decode rate and the full 60 s fault test.

Run: ``.venv/bin/python bench/bench_daq.py [--quick]`` from the repository root.
Prints frames/s of the vectorised decoder (target >= 2e6) and the fault-test accounting
(10 kHz over a pty, 1 % corrupted frames, 50 garbage bursts, 2 unplug/replug events).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import validation_doc

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'src' / 'tribo_drivers'))

from tribo_drivers.core.daq_protocol import DaqDecoder, DaqScaling, encode_frames
from tribo_drivers.core.faultsim import run_daq_fault_scenario


def bench_decode(n: int = 2_000_000, chunk: int = 1 << 20) -> None:
    """Print the decoder's throughput [MB/s] on ``n`` frames (1 % corrupted)."""
    rng = np.random.default_rng(0)
    idx = np.arange(n)
    buf = bytearray(encode_frames(idx, rng.integers(-1000, 1000, n), idx, idx % 77))
    for k in rng.choice(n, n // 100, replace=False):  # 1 % corrupted frames
        buf[int(k) * 20 + 7] ^= 0x10
    data = bytes(buf)
    dec = DaqDecoder(DaqScaling())
    best = 0.0
    for _ in range(3):
        dec = DaqDecoder(DaqScaling())
        t0 = time.perf_counter()
        got = 0
        for pos in range(0, len(data), chunk):
            got += len(dec.feed(data[pos : pos + chunk]))
        got += len(dec.flush())
        dt = time.perf_counter() - t0
        best = max(best, n / dt)
    print(f'decode: {n} frames in chunks of {chunk} B, {got} decoded, '
          f'{dec.stats.crc_errors} CRC errors, best {best / 1e6:.2f} M frames/s '
          f'(target >= 2 M frames/s)')  # fmt: skip
    # small chunks like the driver sees at 10 kHz (~5 ms of data per read)
    dec = DaqDecoder(DaqScaling())
    small = 1000
    t0 = time.perf_counter()
    for pos in range(0, 200_000 * 20, small):
        dec.feed(data[pos : pos + small])
    dt = time.perf_counter() - t0
    print(f'decode: 1000-byte reads: {200_000 / dt / 1e6:.2f} M frames/s '
          f'({dt / 200_000 * 10_000 * 100:.2f} % of a core at 10 kHz)')  # fmt: skip


def main() -> int:
    """Run the DAQ benchmarks (decoder speed, fault test) and print the figures."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--quick', action='store_true', help='10 s fault test instead of 60 s')
    args = ap.parse_args()
    bench_decode()
    duration = 10.0 if args.quick else 60.0
    print(f'fault test: {duration:.0f} s at 10 kHz over a pty ...', flush=True)
    t0 = time.process_time()
    r = run_daq_fault_scenario(
        duration=duration,
        corrupt_fraction=0.01,
        garbage_bursts=50,
        unplugs=2,
        down_time=0.5,
        seed=7,
    )
    cpu = time.process_time() - t0
    for line in r.lines():
        print('  ' + line)
    print(f'  process CPU (emulator + driver pipeline): {100 * cpu / duration:.1f} % of one core')
    return 0 if r.ok else 1


if __name__ == '__main__':
    raise SystemExit(validation_doc.run(__file__, main))
