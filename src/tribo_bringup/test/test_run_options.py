"""`tribo run`'s node selection and driver options come from the node table."""

from __future__ import annotations

import argparse

from tribo_bringup.commands import run


def _args(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    run.register(parser.add_subparsers())
    return parser.parse_args(['run', *argv])


def test_default_selection_is_simulators_estimators_and_monitor() -> None:
    nodes = run.select_nodes(_args())
    assert nodes == ['sim_rig', 'sim_detector', 'friction_estimator', 'wear_monitor',
                     'model_monitor']  # fmt: skip
    assert 'model_monitor' not in run.select_nodes(_args('--no-monitor'))
    assert run.select_nodes(_args('--no-sim', '--bridge'))[-1] == 'live_bridge'


def test_driver_options_start_their_driver_and_set_its_parameters() -> None:
    args = _args('--no-sim', '--daq', '/dev/ttyUSB0', '--can', 'vcan0', '--can-interface',
                 'virtual')  # fmt: skip
    nodes = run.select_nodes(args)
    assert nodes[:2] == ['daq_driver', 'can_driver'] and 'counter_driver' not in nodes
    assert run.driver_overrides(args) == {
        'daq_driver': {'port': '/dev/ttyUSB0'},
        'can_driver': {'channel': 'vcan0', 'interface': 'virtual'},
    }
    # the parameter files of the nodes run, none of a simulator
    files = [p.rsplit('/', 1)[-1] for p in run.default_params(nodes)]
    assert files[:2] == ['daq_driver.yaml', 'can_driver.yaml']
    assert 'sim_rig.yaml' not in [
        p.rsplit('/', 1)[-1] for p in run.default_params(run.select_nodes(_args()))
    ]


def test_an_option_that_only_configures_starts_nothing() -> None:
    args = _args('--can-interface', 'virtual')
    assert 'can_driver' not in run.select_nodes(args)
    assert run.driver_overrides(args) == {}
