"""Simulated rig driver (executable ``sim_rig``): the core rig model in real time.

Runs :func:`tribo_estimation.core.simulate.simulate` chunk by chunk (state
carried between chunks, so the stream equals one long simulation) at the
configured sample rate (10 kHz default) and publishes the three rig channels
as SampleBlocks of ``block_size`` samples on ``rig/torsion_moment`` [N m],
``rig/angular_acceleration`` [rad/s^2] and ``rig/speed`` [rad/s] (relative names
from :mod:`tribo_common.topics`: a namespace moves them).

Stamps: time of the first sample of the block, ``t_start + first_index/fs``
(no scheduling jitter). If the process falls behind real time it catches up
by publishing the overdue blocks (never skipping samples); how far it lags is
logged.

Parameters are the RIG.yaml names (``I1, K1, C1, I2, K2, C2, F_N, R, mu0,
mu_inf, k, nominal_speed, ramp_time``), the measurement noise
(``noise_torque, noise_accel, noise_speed``), ``seed``, ``sample_rate``,
``block_size``, ``duration`` (specs: :data:`PARAMS`) and, for hidden model extensions,
``effects.<name>`` for every field of
:class:`tribo_estimation.core.model.Extensions`.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from typing import Unpack

import numpy as np
from rclpy.node import Node

from tribo_common import topics
from tribo_common.msgconv import make_sample_block
from tribo_common.node_main import NodeOptions, PublishGate, run_node, wait_for_subscribers
from tribo_common.params import ParameterError, declare, declare_specs
from tribo_common.qos import data_qos
from tribo_drivers.nodes.specs import SIM_RIG_PARAMS
from tribo_estimation.core.model import (
    DriveProfile,
    Extensions,
    FrictionLaw,
    RigParams,
    RigState,
)
from tribo_estimation.core.simulate import NoiseSpec, simulate

#: (topic, channel, unit, SimResult field) of the published channels.
CHANNELS = tuple((t.name, t.channel, t.unit, t.channel) for t in topics.RIG_STREAMS)

#: Declared parameters (the rig's from the one rig table): :mod:`tribo_drivers.nodes.specs`.
PARAMS = {p.name: p for p in SIM_RIG_PARAMS}

#: Default sample rate [Hz] and samples per published block.
RIG_SAMPLE_RATE = float(PARAMS['sample_rate'].default)  # type: ignore[arg-type]
RIG_BLOCK_SIZE = int(PARAMS['block_size'].default)  # type: ignore[arg-type]


class SimRigNode(Node):
    """Publishes the simulated rig's sensor streams in real time."""

    def __init__(self, **kwargs: Unpack[NodeOptions]) -> None:
        super().__init__('sim_rig', **kwargs)
        values = declare_specs(self, SIM_RIG_PARAMS)
        self.fs = values.number('sample_rate')
        self.block = values.integer('block_size')
        self.duration = values.number('duration')
        seed = values.integer('seed')
        self.min_subscribers = values.integer('min_subscribers')
        self.wait_subscribers = values.number('wait_subscribers')
        eff: dict[str, float] = {}
        for field in dataclasses.fields(Extensions):
            default = float(field.default)  # type: ignore[arg-type]
            eff[field.name] = float(
                declare(self, f'effects.{field.name}', default, f'hidden extension {field.name}')
            )
        rate = self.fs / self.block
        if not 50.0 <= rate <= 1000.0:
            raise ParameterError(
                f'sample_rate/block_size = {rate:.0f} blocks/s; choose block_size so that the '
                'rate is between 50 and 1000 blocks/s (about 100-500 recommended)'
            )
        try:
            self.rig = RigParams.from_mapping(values.numbers(RigParams.field_names()))
            self.friction = FrictionLaw(
                values.number('mu0'), values.number('mu_inf'), values.number('k')
            )
            self.drive = DriveProfile(values.number('nominal_speed'), values.number('ramp_time'))
            self.extensions = Extensions(**eff)
            self.noise = NoiseSpec(
                values.number('noise_torque'),
                values.number('noise_accel'),
                values.number('noise_speed'),
            )
        except ValueError as exc:
            raise ParameterError(str(exc)) from exc
        self.rng = np.random.default_rng(seed)
        self.state = RigState.at_rest()
        self.index = 0
        self.pubs = [self.create_publisher(_msg_type(), t, data_qos()) for t, *_ in CHANNELS]
        self._stop = threading.Event()
        self._gate = PublishGate()
        self.t_start_ns = 0
        self._thread = threading.Thread(target=self._loop, name='sim_rig', daemon=True)
        self._thread.start()
        self.get_logger().info(
            f'simulated rig at {self.fs:.0f} Hz, blocks of {self.block} samples, '
            f'w0 = {self.drive.nominal_speed:.3f} rad/s, '
            f'hidden effects: {self._effects_text()}'
        )

    def _effects_text(self) -> str:
        on = [
            f'{f.name}={getattr(self.extensions, f.name)}'
            for f in dataclasses.fields(Extensions)
            if f.name != 'bearing_reg_speed' and getattr(self.extensions, f.name) != 0.0
        ]
        return ', '.join(on) if on else 'none'

    def step(self) -> None:
        """Simulate and publish the next block (nothing once the node is closed)."""
        res = simulate(
            self.rig,
            self.friction,
            self.drive,
            self.block / self.fs,
            self.fs,
            initial=self.state,
            extensions=self.extensions,
            noise=self.noise,
            seed=self.rng,
        )
        self.state = res.final_state
        stamp = self.t_start_ns + round(self.index * 1e9 / self.fs)
        with self._gate.batch() as ok:
            if not ok:
                return
            for pub, (_topic, channel, unit, field) in zip(self.pubs, CHANNELS, strict=True):
                pub.publish(
                    make_sample_block(
                        getattr(res, field),
                        first_index=self.index,
                        sample_rate=self.fs,
                        stamp_ns=stamp,
                        channel=channel,
                        unit=unit,
                    )
                )
        self.index += self.block

    def _wait_for_subscribers(self) -> None:
        """Hold the stream until every rig topic has ``min_subscribers`` subscriptions.

        The wait lasts at most ``wait_subscribers`` [s], then a short settle time
        (:func:`tribo_common.node_main.wait_for_subscribers`).
        """
        if self.min_subscribers <= 0:
            return
        pubs = {t: p for p, (t, *_) in zip(self.pubs, CHANNELS, strict=True)}
        short = wait_for_subscribers(pubs, self.wait_subscribers, self.min_subscribers, self._stop)
        if short and not self._stop.is_set():
            counts = [p.get_subscription_count() for p in self.pubs]
            self.get_logger().warning(
                f'streaming with {counts} subscriptions (wanted {self.min_subscribers} '
                f'after {self.wait_subscribers:g} s)'
            )

    def _loop(self) -> None:
        # compile (or load from cache) the numba kernel before the clock starts
        simulate(self.rig, self.friction, self.drive, 1.0 / self.fs, self.fs)
        self._wait_for_subscribers()
        if self._stop.is_set():
            return
        self.t_start_ns = self.get_clock().now().nanoseconds
        self.get_logger().info('streaming started')
        t0 = time.monotonic()
        last_warn = t0
        n_total = round(self.duration * self.fs) if self.duration > 0 else None
        while not self._stop.is_set():
            if n_total is not None and self.index >= n_total:
                self.get_logger().info(f'simulated {self.duration} s; stopping the stream')
                return
            due = t0 + (self.index + self.block) / self.fs
            delay = due - time.monotonic()
            if delay > 0:
                self._stop.wait(delay)
                continue
            if -delay > 0.5 and time.monotonic() - last_warn > 10.0:
                self.get_logger().warning(f'running {-delay:.2f} s behind real time')
                last_warn = time.monotonic()
            try:
                self.step()
            except Exception as exc:  # keep the failure visible, stop cleanly
                self.get_logger().error(f'simulation stopped: {exc}')
                return

    def close(self) -> None:
        """Stop the simulation thread; nothing is published after this returns."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        self._gate.close()


def _msg_type() -> type:
    from tribo_msgs.msg import SampleBlock

    msg_type: type = SampleBlock  # the generated message class (untyped module)
    return msg_type


def main(args: list[str] | None = None) -> None:
    """Entry point of ``sim_rig``."""
    raise SystemExit(run_node(SimRigNode, args))


if __name__ == '__main__':
    main()
