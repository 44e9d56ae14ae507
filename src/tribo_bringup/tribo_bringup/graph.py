"""Graph runner: the chosen tribo nodes in one process on one executor.

The stand-in for a launch file on machines without ``ros2 launch`` (the
packages ship real launch files in ``launch/`` for full ROS installs).
Parameters come from ROS parameter files (``--params-file``) and from a
RIG.yaml, whose keys are the rig nodes' parameter names.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tribo_bringup.errors import BringupError, ConfigError
from tribo_common.node_main import spin_background
from tribo_common.nodes import BY_NAME
from tribo_common.topics import normalize_namespace

if TYPE_CHECKING:
    from rclpy.node import Node


def rig_overrides(rig_yaml: str | Path) -> dict[str, dict[str, object]]:
    """Parameter values per node from a RIG.yaml.

    The file is read and validated by the core loader
    (:func:`tribo_estimation.core.config.load_rig_config`); its keys are the
    rig nodes' parameter names, ``effects:`` become ``effects.<name>``.
    """
    from tribo_estimation.core.config import load_rig_config

    cfg = load_rig_config(rig_yaml)
    common: dict[str, object] = {f.name: float(getattr(cfg.rig, f.name)) for f in fields(cfg.rig)}
    common.update(
        mu0=cfg.friction.mu0,
        mu_inf=cfg.friction.mu_inf,
        k=cfg.friction.k,
        nominal_speed=cfg.drive.nominal_speed,
    )
    sim = dict(common)
    sim.update(
        ramp_time=cfg.drive.ramp_time,
        noise_torque=cfg.noise.torque,
        noise_accel=cfg.noise.accel,
        noise_speed=cfg.noise.speed,
    )
    for f in fields(cfg.extensions):
        sim[f'effects.{f.name}'] = float(getattr(cfg.extensions, f.name))
    return {
        'sim_rig': sim,
        'friction_estimator': {**common, 'ramp_time': cfg.drive.ramp_time},
        'model_monitor': {**common, 'ramp_time': cfg.drive.ramp_time},
        'live_bridge': {'C1': common['C1']},
    }


@dataclass
class Graph:
    """A set of nodes spinning in one process.

    Args:
        nodes: node names (rows of :data:`tribo_common.nodes.NODES`).
        params_files: ROS 2 parameter files applied to every node (by node name).
        overrides: per-node parameter overrides (name -> value).
        namespace: namespace of every node (``''``: the root; ``rigB``: topics
            ``/rigB/rig/...``), as ``--ros-args -r __ns:=/rigB`` would set it.
    """

    nodes: Sequence[str]
    params_files: Sequence[str | Path] = ()
    overrides: dict[str, dict[str, Any]] = field(default_factory=dict)
    namespace: str = ''
    extra_nodes: list[Any] = field(default_factory=list)
    _instances: list[Any] = field(default_factory=list, init=False)

    def init_ros(self, ros_args: Sequence[str] = ()) -> None:
        """Initialise rclpy with the parameter files (no node created yet).

        rclpy's signal handlers are not installed: Ctrl-C raises KeyboardInterrupt
        and the context stays valid until :meth:`close` has stopped the nodes'
        threads.
        """
        import rclpy
        from rclpy.signals import SignalHandlerOptions

        args = ['tribo-run', '--ros-args']
        for f in self.params_files:
            if not Path(f).is_file():
                raise ConfigError(f'{f}: no such parameter file')
            args += ['--params-file', str(f)]
        args += list(ros_args)
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)

    def add(self, name: str, overrides: Mapping[str, object] | None = None) -> Node:
        """Create node ``name`` (a row of :data:`tribo_common.nodes.NODES`) with its overrides.

        A parameter the node refuses raises :class:`ConfigError` naming the node.
        """
        from rclpy.parameter import Parameter

        from tribo_common.params import ParameterError

        if name not in BY_NAME:
            raise ConfigError(f'unknown node {name!r}; known: {", ".join(BY_NAME)}')
        cls = BY_NAME[name].node_class()
        values = {**self.overrides.get(name, {}), **(overrides or {})}
        try:
            node: Node = cls(
                parameter_overrides=[Parameter(k, value=v) for k, v in values.items()],
                namespace=normalize_namespace(self.namespace) or '/',
            )
        except ParameterError as exc:  # a bad value in a parameter file or a RIG.yaml
            raise ConfigError(f'{name}: {exc}') from exc
        self._instances.append(node)
        return node

    def start(self, ros_args: Sequence[str] = ()) -> None:
        """Initialise rclpy and create the nodes in list order."""
        self.init_ros(ros_args)
        for name in self.nodes:
            self.add(name)

    def spin(
        self,
        duration: float = 0.0,
        progress: Callable[[float], None] | None = None,
        stop: threading.Event | None = None,
    ) -> None:
        """Spin all nodes until ``duration`` [s] passed (0: until Ctrl-C) or ``stop`` is set."""
        # single-threaded: rclpy's MultiThreadedExecutor costs about a core at a few
        # hundred messages/s; the nodes do their heavy work in their own threads
        from rclpy.executors import SingleThreadedExecutor

        executor = SingleThreadedExecutor()
        for node in [*self._instances, *self.extra_nodes]:
            executor.add_node(node)
        spinner, stop = spin_background(executor, stop)
        t0 = time.monotonic()
        last = t0
        try:
            while not stop.is_set():
                now = time.monotonic()
                if duration and now - t0 >= duration:
                    break
                if progress is not None and now - last >= 5.0:
                    progress(now - t0)
                    last = now
                time.sleep(0.05)
        except KeyboardInterrupt:
            _ignore_sigint()  # the graph is ending: a second Ctrl-C must not cut the shutdown
        finally:
            stop.set()
            spinner.join(timeout=5.0)
            executor.shutdown(timeout_sec=2.0)
        if spinner.error is not None:  # a callback failed: the graph stopped there
            raise BringupError(f'the graph stopped: {spinner.error!r}') from spinner.error

    def close(self) -> None:
        """Stop and destroy the nodes, then shut rclpy down.

        Each node's ``close`` stops its threads while the context is still valid. A
        further Ctrl-C during the shutdown is ignored (it would cut short the
        recorder's last write or the wear monitor's state file).
        """
        import signal

        from rclpy.utilities import try_shutdown

        previous = None
        if threading.current_thread() is threading.main_thread():
            previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            for node in [*self._instances, *self.extra_nodes]:
                close = getattr(node, 'close', None)
                if callable(close):
                    close()
                node.destroy_node()
            self._instances.clear()
            try_shutdown()
        finally:
            if previous is not None:
                signal.signal(signal.SIGINT, previous)


def _ignore_sigint() -> None:
    """Ignore further SIGINTs in this process (main thread only)."""
    import signal

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
