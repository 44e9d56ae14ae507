"""``tribo demo`` set-up: rig file with the hidden effect, output directory safety.

The demo itself (a minute on the live graph) runs with ``make demo``; these
tests cover what it decides before the graph starts.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest
import yaml

from tribo_bringup.commands import demo
from tribo_bringup.errors import ConfigError

CONFIG = Path(__file__).resolve().parents[4] / 'config'


def test_every_effect_family_has_a_demo_rig() -> None:
    from tribo_estimation.core.discrepancy import candidates

    for fam in candidates.families():
        rig, source = demo.rig_for_demo(None, fam)
        if (CONFIG / f'rig_hidden_{fam}.yaml').is_file():
            assert source.endswith(f'rig_hidden_{fam}.yaml')
        else:  # config/rig.yaml with the demo values of one of its forms
            assert source.endswith(f'rig.yaml + {fam} demo values'), source
            demo_values = [f.demo_effects for f in candidates.forms(fam) if f.demo_effects]
            assert rig['effects'] == dict(demo_values[0]), fam
        assert rig['effects'], fam  # the effect is switched on
    with pytest.raises(ConfigError, match='unknown effect'):
        demo.rig_for_demo(None, 'no_such_effect')


def test_every_simulated_form_has_a_demo_rig_that_switches_it_on(tmp_path: Path) -> None:
    # ``tribo demo --effect FORM`` for every form whose parameters the simulated rig
    # takes (model extensions): its rig file, or config/rig.yaml with its demo values,
    # which set each of its parameters and nothing else; the rig loads with the
    # extensions away from the paper's model. A form fitted per shooting segment (the
    # saturating drift) has no extension to simulate: it is refused by name
    import dataclasses

    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.discrepancy import candidates
    from tribo_estimation.core.model import Extensions
    from tribo_estimation.core.simulate import simulate

    fields = {f.name for f in dataclasses.fields(Extensions)}
    refused = []
    for name in candidates.names():
        params = {p.name for p in candidates.get(name).params}
        if not params <= fields:
            with pytest.raises(ConfigError, match=f'{name}.*no demo values'):
                demo.rig_for_demo(None, name)
            refused.append(name)
            continue
        rig, _ = demo.rig_for_demo(None, name)
        if not (CONFIG / f'rig_hidden_{name}.yaml').is_file():
            assert set(rig['effects']) == params, name
        path = tmp_path / f'{name}.yaml'
        path.write_text(yaml.safe_dump(rig))
        cfg = load_rig_config(path)
        assert cfg.extensions != Extensions(), name
        # the simulated rig's torsion moment moves (0.5 s at 5 kHz, noise-free)
        on, off = (
            simulate(cfg.rig, cfg.friction, cfg.drive, 0.5, 5000.0, extensions=ext).torsion_moment
            for ext in (cfg.extensions, None)
        )
        assert float(np.max(np.abs(on - off))) > 1e-3, name
    assert refused == ['friction_drift_saturating']


def test_none_is_the_nominal_rig() -> None:
    rig, source = demo.rig_for_demo(None, 'none')
    assert source.endswith('rig.yaml') and not rig.get('effects')


def test_explicit_rig_file_is_used_and_validated(tmp_path: Path) -> None:
    data = yaml.safe_load((CONFIG / 'rig.yaml').read_text())
    good = tmp_path / 'mine.yaml'
    good.write_text(yaml.safe_dump({**data, 'mu0': 0.2}))
    rig, source = demo.rig_for_demo(str(good), 'ignored')
    assert rig['mu0'] == 0.2 and source == str(good)
    bad = tmp_path / 'bad.yaml'
    bad.write_text(yaml.safe_dump({k: v for k, v in data.items() if k != 'C1'}))
    with pytest.raises(Exception, match='C1'):
        demo.rig_for_demo(str(bad), 'none')


def test_unknown_effect_is_rejected() -> None:
    with pytest.raises(ConfigError, match='unknown effect'):
        demo.rig_for_demo(None, 'no_such_effect')


def test_out_dir_of_someone_else_is_never_cleared(tmp_path: Path) -> None:
    foreign = tmp_path / 'results'
    foreign.mkdir()
    (foreign / 'thesis.txt').write_text('keep me')
    with pytest.raises(ConfigError, match='not a tribo demo directory'):
        demo.prepare_out(foreign)
    assert (foreign / 'thesis.txt').read_text() == 'keep me'


def test_previous_demo_bag_and_report_are_replaced(tmp_path: Path) -> None:
    out = tmp_path / 'demo_output'
    demo.prepare_out(out)
    (out / 'bag').mkdir()
    (out / 'report').mkdir()
    (out / 'report' / 'report.html').write_text('old')
    (out / 'notes.txt').write_text('kept')
    demo.prepare_out(out)
    assert not (out / 'bag').exists() and not (out / 'report').exists()
    assert (out / 'notes.txt').read_text() == 'kept'


def test_duration_is_checked() -> None:
    args = argparse.Namespace(duration=0.5, discrepancy_seconds=5.0)
    with pytest.raises(ConfigError, match='--duration'):
        demo.run(args)


@pytest.mark.ros
@pytest.mark.slow
def test_short_demo_end_to_end(tmp_path: Path) -> None:
    """3 s on the live graph, recorded and reported (the minute-long run is `make demo`)."""
    import json
    import os
    import signal
    import subprocess
    import sys

    pytest.importorskip('rclpy', reason='needs rclpy: run under `make test`')
    pytest.importorskip('tribo_msgs.msg', reason='needs the built workspace (source env.sh)')
    out = tmp_path / 'demo'
    harness = (
        'import argparse, sys\n'
        'from tribo_bringup.commands import demo\n'
        'p = argparse.ArgumentParser(); demo.register(p.add_subparsers())\n'
        'a = p.parse_args(sys.argv[1:]); sys.exit(a.func(a))\n'
    )
    env = {
        **os.environ,
        'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
    }
    args = [sys.executable, '-c', harness, 'demo', '--duration', '3', '--out', str(out)]
    args += ['--no-discrepancy', '--no-bridge']
    proc = subprocess.Popen(
        args, env=env, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT
    )
    try:
        text, _ = proc.communicate(timeout=240)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGINT)
        text, _ = proc.communicate(timeout=30)
        pytest.fail(f'demo did not finish: {text.decode()[-2000:]}')
    log = text.decode(errors='replace')
    assert proc.returncode == 0, log[-3000:]
    assert f'Report: {(out / "report" / "report.html").resolve()}' in log
    results = json.loads((out / 'report' / 'results.json').read_text())
    assert len(results['summary']) == 5
    streams = {s['topic']: s for s in results['session']['streams']}
    torsion = streams['/rig/torsion_moment']
    # the recorder is subscribed before the rig starts: the record begins at sample 0
    assert torsion['first_index'] == 0 and results['session']['missing_samples'] == 0
    # 3 s at 10 kHz recorded (>= 2.5 s: the stop is not sample-exact)
    assert torsion['samples'] >= 25_000
    assert (out / 'rig_used.yaml').is_file() and (out / 'bag' / 'metadata.yaml').is_file()
