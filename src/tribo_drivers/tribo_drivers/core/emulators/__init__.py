"""Device emulators for tests and benchmarks (no hardware needed).

* :class:`PtyPort` a pseudo-terminal pair (``os.openpty``) with a stable symlink path, so a
  driver can open "the device" by name; ``unplug()`` closes the pair (the driver's reads fail
  with EIO like a vanished USB adapter) and ``replug()`` creates a fresh pair behind the same
  path.
* :class:`DaqEmulator` streams DAQ frames in real time with injected faults (corrupted frames,
  dropped bytes, garbage bursts, unplug/replug) and records the ground truth: which sample
  indices went out intact, which were damaged, which were never sent.
* :class:`CounterEmulator` the radiation counter: answers ``$DWELL`` with ``$ACK`` and emits
  one ``$CNT`` line per dwell (optionally with wrong checksums and garbage lines).
* :class:`CanEmulator` sends the CAN sensor frames to any python-can bus (e.g. ``virtual``);
  :class:`SlcanPtyDevice` is a serial-line CAN adapter (slcan / Lawicel protocol) on a pty.
"""

from .can import CanEmulator, SlcanPtyDevice, default_can_signal
from .counter import CounterEmulator
from .daq import DaqEmulator, DaqTruth, default_daq_signal
from .pty import PtyPort

__all__ = [
    'CanEmulator',
    'CounterEmulator',
    'DaqEmulator',
    'DaqTruth',
    'PtyPort',
    'SlcanPtyDevice',
    'default_can_signal',
    'default_daq_signal',
]
