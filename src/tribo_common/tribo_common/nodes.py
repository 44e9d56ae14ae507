"""The tribo graph's nodes: the one table of executables, kinds, parameters and launch files.

The launch files (``tribo_bringup/launch``), the graph runner
(:mod:`tribo_bringup.graph`), ``tribo run``'s driver options, the parameter
reference (:mod:`tribo_bringup.paramdocs` -> ``docs/parameters.md``), the
packages' ``setup.py`` console scripts and the tests take their node names from
here: a new driver is its decoder, its node module and one row of :data:`NODES`.

Standard library only (no rclpy, no sibling package imported at load time): each
``setup.py`` reads this table from the source tree while colcon builds, and the
class and parameter specs of a row are imported only when asked for
(:meth:`NodeInfo.node_class`, :meth:`NodeInfo.param_specs`).
"""

from __future__ import annotations

import enum
import importlib
from dataclasses import dataclass

from tribo_common.paramspec import ParamSpec


class NodeKind(enum.Enum):
    """What a node does in the graph."""

    #: stands in for a device: publishes the streams a driver would (simulated rig, detector)
    SIMULATOR = 'simulator'
    #: reads a device and publishes its streams and ``/diagnostics``
    DRIVER = 'driver'
    #: turns the measured streams into results (friction coefficients, wear)
    ESTIMATOR = 'estimator'
    #: compares the streams with the rig model (model discrepancy)
    MONITOR = 'monitor'
    #: serves the graph's topics to viewers outside ROS
    BRIDGE = 'bridge'


@dataclass(frozen=True)
class RunOption:
    """A ``tribo run`` option that sets one parameter of a node.

    Attributes
    ----------
    flag
        The option, e.g. ``--daq``.
    metavar
        Its value's name in the help, e.g. ``PORT``.
    parameter
        The node parameter the value sets, e.g. ``port``.
    help
        The option's help text.
    starts
        True if giving the option also starts the node (else it only configures it).
    """

    flag: str
    metavar: str
    parameter: str
    help: str
    starts: bool = True

    @property
    def dest(self) -> str:
        """Return the option's argparse destination (``--can-interface``: ``can_interface``)."""
        return self.flag.lstrip('-').replace('-', '_')


@dataclass(frozen=True)
class NodeInfo:
    """One node of the graph (one executable).

    Attributes
    ----------
    name
        Executable and node name (``ros2 run PACKAGE NAME``).
    package
        ROS package that installs the executable.
    module
        Python module holding the node class and the executable's ``main()``.
    class_name
        Node class name (takes rclpy's Node keyword arguments).
    kind
        What the node does (:class:`NodeKind`).
    lifecycle
        True for a managed (lifecycle) node.
    params
        Where its parameter specs are, ``'module:NAME'`` each (tuples of
        :class:`~tribo_common.paramspec.ParamSpec`, concatenated in order).
    config
        Its ROS parameter file in ``config/`` (``''``: none).
    launch
        The launch files that start it (``'sim'``: ``sim.launch.py``, ``'hardware'``:
        ``hardware.launch.py``).
    run_options
        The ``tribo run`` options of the node (the first with ``starts`` starts it).
    description
        What the node does, one line.
    """

    name: str
    package: str
    module: str
    class_name: str
    kind: NodeKind
    lifecycle: bool
    params: tuple[str, ...]
    config: str
    launch: tuple[str, ...]
    run_options: tuple[RunOption, ...]
    description: str

    @property
    def entry_point(self) -> str:
        """Return the console-script line of ``setup.py`` (``name = module:main``)."""
        return f'{self.name} = {self.module}:main'

    def node_class(self) -> type:
        """Import and return the node class (imports rclpy and the node's package).

        Returns
        -------
        type
            The class named :attr:`class_name` in :attr:`module`.
        """
        cls: type = getattr(importlib.import_module(self.module), self.class_name)
        return cls

    def param_specs(self) -> tuple[ParamSpec, ...]:
        """Import and return the node's parameter specs (no rclpy).

        Returns
        -------
        tuple of ParamSpec
            The specs of :attr:`params`, in order.
        """
        specs: list[ParamSpec] = []
        for ref in self.params:
            module, _, attr = ref.partition(':')
            specs += getattr(importlib.import_module(module), attr)
        return tuple(specs)


_DRIVER_SPECS = 'tribo_drivers.nodes.specs'

#: Every node of the graph, in start order (simulators and drivers first).
NODES: tuple[NodeInfo, ...] = (
    NodeInfo(
        'sim_rig', 'tribo_drivers', 'tribo_drivers.nodes.sim_rig', 'SimRigNode',
        NodeKind.SIMULATOR, False, (f'{_DRIVER_SPECS}:SIM_RIG_PARAMS',), 'sim_rig.yaml',
        ('sim',), (),
        'simulated rig in real time: torsion moment, acceleration, speed (Equ. 1-8)',
    ),
    NodeInfo(
        'sim_detector', 'tribo_drivers', 'tribo_drivers.nodes.sim_detector', 'SimDetector',
        NodeKind.SIMULATOR, False, (f'{_DRIVER_SPECS}:SIM_DETECTOR_PARAMS',), '',
        ('sim',), (),
        'simulated nVCT detector: counts per dwell of a wear test',
    ),
    NodeInfo(
        'daq_driver', 'tribo_drivers', 'tribo_drivers.nodes.daq_driver', 'DaqDriver',
        NodeKind.DRIVER, True,
        (f'{_DRIVER_SPECS}:DRIVER_PARAMS', f'{_DRIVER_SPECS}:DAQ_PARAMS'), 'daq_driver.yaml',
        ('hardware',),
        (RunOption('--daq', 'PORT', 'port', 'also run the serial DAQ driver on PORT'),),
        'serial DAQ: torsion moment, acceleration and speed at 10 kHz',
    ),
    NodeInfo(
        'can_driver', 'tribo_drivers', 'tribo_drivers.nodes.can_driver', 'CanDriver',
        NodeKind.DRIVER, True,
        (f'{_DRIVER_SPECS}:DRIVER_PARAMS', f'{_DRIVER_SPECS}:CAN_PARAMS'), 'can_driver.yaml',
        ('hardware',),
        (
            RunOption(
                '--can', 'CHANNEL', 'channel', 'also run the CAN sensor-module driver on CHANNEL'
            ),
            RunOption(
                '--can-interface', 'NAME', 'interface',
                'python-can interface of --can (default: can_driver.yaml, socketcan)',
                starts=False,
            ),
        ),
        'CAN sensor modules: acceleration, speed, normal force, oil temperature',
    ),
    NodeInfo(
        'counter_driver', 'tribo_drivers', 'tribo_drivers.nodes.counter_driver',
        'CounterDriver', NodeKind.DRIVER, True,
        (f'{_DRIVER_SPECS}:DRIVER_PARAMS', f'{_DRIVER_SPECS}:COUNTER_PARAMS'),
        'counter_driver.yaml', ('hardware',),
        (RunOption('--counter', 'PORT', 'port', 'also run the radiation counter driver'),),
        'radiation counter (nVCT): counts per dwell',
    ),
    NodeInfo(
        'friction_estimator', 'tribo_estimation', 'tribo_estimation.nodes.friction_estimator',
        'FrictionEstimatorNode', NodeKind.ESTIMATOR, False,
        ('tribo_estimation.nodes.specs:FRICTION_ESTIMATOR_PARAMS',), 'friction_estimator.yaml',
        ('sim', 'hardware'), (),
        'observer friction moment and mu0, mu_inf per 1 s block (paper 2.5)',
    ),
    NodeInfo(
        'model_monitor', 'tribo_estimation', 'tribo_estimation.nodes.model_monitor',
        'ModelMonitorNode', NodeKind.MONITOR, False,
        ('tribo_estimation.nodes.specs:MODEL_MONITOR_PARAMS',), 'model_monitor.yaml',
        ('sim',), (),
        'live model monitor: the missing-physics verdict over a rolling window',
    ),
    NodeInfo(
        'wear_monitor', 'tribo_nvct', 'tribo_nvct.nodes.wear_monitor', 'WearMonitor',
        NodeKind.ESTIMATOR, False, ('tribo_nvct.nodes.specs:WEAR_MONITOR_PARAMS',),
        'wear_monitor.yaml', ('sim', 'hardware'), (),
        'wear volume, height and rate per dwell from the detector counts (nVCT)',
    ),
    NodeInfo(
        'live_bridge', 'tribo_bringup', 'tribo_bringup.nodes.live_bridge', 'LiveBridgeNode',
        NodeKind.BRIDGE, False, ('tribo_bringup.nodes.specs:LIVE_BRIDGE_PARAMS',), '',
        (), (),
        'Foxglove WebSocket bridge: the graph live, sample streams down-sampled',
    ),
)  # fmt: skip

#: Node name -> its row.
BY_NAME: dict[str, NodeInfo] = {n.name: n for n in NODES}


def of_kind(*kinds: NodeKind) -> tuple[NodeInfo, ...]:
    """Return the nodes of the given kinds, in table order.

    Parameters
    ----------
    *kinds : NodeKind
        The kinds wanted.

    Returns
    -------
    tuple of NodeInfo
        Their rows.
    """
    return tuple(n for n in NODES if n.kind in kinds)


def launched_by(launch: str) -> tuple[NodeInfo, ...]:
    """Return the nodes a launch file starts, in table order.

    Parameters
    ----------
    launch : str
        ``'sim'`` or ``'hardware'`` (``<launch>.launch.py``).

    Returns
    -------
    tuple of NodeInfo
        Their rows.
    """
    return tuple(n for n in NODES if launch in n.launch)


def console_scripts(package: str) -> list[str]:
    """Return the console-script lines of a package's node executables (for ``setup.py``).

    Parameters
    ----------
    package : str
        ROS package name.

    Returns
    -------
    list of str
        ``'name = module:main'`` per node the package installs.
    """
    return [n.entry_point for n in NODES if n.package == package]
