"""The node table: one row per executable, consistent fields (no rclpy needed)."""

from __future__ import annotations

import pytest

from tribo_common import nodes
from tribo_common.nodes import NodeKind


def test_names_flags_and_launch_files_are_unique_and_known() -> None:
    assert len(nodes.BY_NAME) == len(nodes.NODES) == 9
    flags = [o.flag for n in nodes.NODES for o in n.run_options]
    assert len(flags) == len(set(flags)), flags
    for n in nodes.NODES:
        assert set(n.launch) <= {'sim', 'hardware'}, n.name
        assert n.module.startswith(f'{n.package}.nodes.'), n.name
        assert n.config in ('', f'{n.name}.yaml'), n.name
        assert n.description and n.params, n.name


def test_every_driver_is_a_lifecycle_node_started_by_one_option() -> None:
    drivers = nodes.of_kind(NodeKind.DRIVER)
    assert {d.name for d in drivers} == {'daq_driver', 'can_driver', 'counter_driver'}
    for d in drivers:
        assert d.lifecycle and d.launch == ('hardware',), d.name
        assert sum(o.starts for o in d.run_options) == 1, d.name
    # only drivers are lifecycle nodes or have tribo run options
    others = [n for n in nodes.NODES if n.kind is not NodeKind.DRIVER]
    assert not any(n.lifecycle or n.run_options for n in others)


def test_launch_files_and_console_scripts_follow_the_table() -> None:
    assert [n.name for n in nodes.launched_by('sim')] == [
        'sim_rig', 'sim_detector', 'friction_estimator', 'model_monitor', 'wear_monitor'
    ]  # fmt: skip
    assert 'sim_rig' not in {n.name for n in nodes.launched_by('hardware')}
    assert nodes.console_scripts('tribo_nvct') == [
        'wear_monitor = tribo_nvct.nodes.wear_monitor:main'
    ]
    assert nodes.console_scripts('tribo_msgs') == []


@pytest.mark.parametrize('flag', ['--can-interface', '--daq'])
def test_run_option_dest_is_argparse_s(flag: str) -> None:
    import argparse

    (opt,) = [o for n in nodes.NODES for o in n.run_options if o.flag == flag]
    parser = argparse.ArgumentParser()
    parser.add_argument(opt.flag, metavar=opt.metavar)
    assert hasattr(parser.parse_args([opt.flag, 'x']), opt.dest)


def test_param_specs_concatenate_the_sources_in_order() -> None:
    from tribo_drivers.nodes.specs import CAN_PARAMS, DRIVER_PARAMS

    assert nodes.BY_NAME['can_driver'].param_specs() == (*DRIVER_PARAMS, *CAN_PARAMS)
