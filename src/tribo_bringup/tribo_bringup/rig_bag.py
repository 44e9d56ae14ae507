"""Rig sample streams written straight into a bag, as the recorder would have them.

:class:`RigBagWriter` takes chunks of the three rig channels (time s, torsion
moment N m, chamber acceleration rad/s^2, shaft speed rad/s) and writes them as
``tribo_msgs/SampleBlock`` messages on the topic table's ``rig/*`` streams
(``tribo_common.topics``) through :class:`tribo_bringup.bag_write.BagWriter`:
one message per channel every ``message_samples`` samples, header stamp = time of
the first sample, ``first_index`` counted from the stream's start. The output is
a rosbag2 directory, or a single ``.mcap`` file; either appears only when
complete (written beside the target and renamed on :meth:`RigBagWriter.close`).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import numpy.typing as npt

from tribo_bringup.errors import BagError
from tribo_common import topics as topic_table

FloatArray = npt.NDArray[np.float64]

#: Samples per SampleBlock message (at 10 kHz: 40 messages per second and channel).
MESSAGE_SAMPLES = 250


class RigBagWriter:
    """Write rig channel chunks as SampleBlock streams into a new bag.

    Parameters
    ----------
    out : str or Path
        The bag: a directory (rosbag2) or a ``.mcap`` file; must not exist.
    fs : float
        Sample rate [Hz].
    t0_ns : int
        Stamp of the first sample [ns].
    message_samples : int
        Samples per message.
    """

    def __init__(
        self, out: str | Path, fs: float, t0_ns: int = 0, message_samples: int = MESSAGE_SAMPLES
    ) -> None:
        from tribo_bringup.bag_write import BagWriter

        self.out = Path(out)
        if self.out.exists():
            raise BagError(f'{self.out}: already exists (choose a new --out)')
        self.fs = float(fs)
        self.t0_ns = int(t0_ns)
        self.message_samples = int(message_samples)
        self.out.parent.mkdir(parents=True, exist_ok=True)
        self._single = self.out.suffix.lower() == '.mcap'
        self._stage = self.out.parent / f'.{self.out.name}.partial-{os.getpid()}'
        shutil.rmtree(self._stage, ignore_errors=True)
        self._stage.mkdir()
        self._bag = self._stage / (self.out.stem if self._single else self.out.name)
        self._writer = BagWriter(self._bag)
        self._writer.open()
        self._streams = [(t.resolve(), t.channel, t.unit) for t in topic_table.RIG_STREAMS]
        for topic, _, _ in self._streams:
            self._writer.add_topic(topic, 'tribo_msgs/msg/SampleBlock')
        self.samples = 0

    def write(self, torsion: FloatArray, accel: FloatArray, speed: FloatArray) -> None:
        """Append the next samples of the three channels (equal lengths, SI).

        Parameters
        ----------
        torsion : ndarray
            Torsion moment C1*phi1 [N m].
        accel : ndarray
            Chamber angular acceleration [rad/s^2].
        speed : ndarray
            Shaft speed [rad/s].
        """
        from tribo_bringup import bagio

        store = bagio.typestore()
        sample_block = store.types['tribo_msgs/msg/SampleBlock']
        header_t = store.types['std_msgs/msg/Header']
        time_t = store.types['builtin_interfaces/msg/Time']
        data = {'torsion_moment': torsion, 'angular_acceleration': accel, 'speed': speed}
        n = len(torsion)
        for a in range(0, n, self.message_samples):
            b = min(n, a + self.message_samples)
            index = self.samples + a
            stamp = self.t0_ns + round(index * 1e9 / self.fs)
            for topic, channel, unit in self._streams:
                msg = sample_block(
                    header=header_t(
                        stamp=time_t(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=channel
                    ),
                    sample_rate=self.fs,
                    first_index=index,
                    unit=unit,
                    data=np.ascontiguousarray(data[channel][a:b], dtype=np.float64),
                )
                self._writer.write_msg(topic, stamp, msg)
        self.samples += n

    def close(self) -> Path:
        """Finish the bag and move it into place.

        Returns
        -------
        Path
            The bag written.
        """
        self._writer.close()
        if self._single:
            os.replace(self._bag / f'{self._bag.name}.mcap', self.out)
        else:
            os.rename(self._bag, self.out)
        shutil.rmtree(self._stage, ignore_errors=True)
        return self.out

    def abort(self) -> None:
        """Drop everything written (nothing appears at ``out``)."""
        self._writer.close()
        shutil.rmtree(self._stage, ignore_errors=True)
