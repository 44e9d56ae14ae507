"""Stale numba caches are dropped when compiled code or the layout changes (and only then)."""

from __future__ import annotations

from pathlib import Path

from tribo_estimation.core.kernel.cachecheck import purge_stale_caches


def _tree(root: Path) -> tuple[Path, Path]:
    kernel = root / 'tribo_estimation' / 'core' / 'kernel'
    kernel.mkdir(parents=True)
    (kernel / 'layout.py').write_text('NS = 12\n')
    (kernel / 'state.py').write_text('# tuple builders\n@njit\ndef f(): pass\n')
    (kernel / 'equations.py').write_text('@njit(inline="always")\ndef g(): return 1\n')
    (kernel / 'notes.py').write_text('# no compiled code\n')
    cache = root / 'tribo_estimation' / 'core' / 'sticks' / '__pycache__'
    cache.mkdir(parents=True)
    return kernel, cache


def test_caches_dropped_on_a_layout_change_only(tmp_path: Path) -> None:
    kernel, cache = _tree(tmp_path)
    files = [cache / 'detect.f-10.py311.nbi', cache / 'detect.f-10.py311.1.nbc']
    for f in files:
        f.write_bytes(b'x')
    # first check: no stamp yet, so the caches cannot be trusted
    assert purge_stale_caches(kernel)
    assert not any(f.exists() for f in files)
    # unchanged layout: caches built since are kept
    for f in files:
        f.write_bytes(b'x')
    assert not purge_stale_caches(kernel)
    assert all(f.exists() for f in files)
    # a new state slot in layout.py: every cache of the package goes
    (kernel / 'layout.py').write_text('NS = 13\n')
    assert purge_stale_caches(kernel)
    assert not any(f.exists() for f in files)
    # other files are never touched
    keep = cache / 'detect.cpython-311.pyc'
    keep.write_bytes(b'x')
    (kernel / 'state.py').write_text('# changed\n')
    purge_stale_caches(kernel)
    assert keep.exists()


def test_caches_dropped_when_an_inlined_function_changes(tmp_path: Path) -> None:
    # a function compiled into shooting's (kernel.equations, inline='always') changes:
    # shooting's cache, keyed on its own file, would hold the old machine code
    kernel, cache = _tree(tmp_path)
    files = [cache / 'shoot.f-10.py311.nbi', cache / 'shoot.f-10.py311.1.nbc']
    purge_stale_caches(kernel)
    for f in files:
        f.write_bytes(b'x')
    (kernel / 'equations.py').write_text('@njit(inline="always")\ndef g(): return 2\n')
    assert purge_stale_caches(kernel)
    assert not any(f.exists() for f in files)
    # a source without compiled code changes: the caches stay
    for f in files:
        f.write_bytes(b'x')
    (kernel / 'notes.py').write_text('# edited\n')
    assert not purge_stale_caches(kernel)
    assert all(f.exists() for f in files)
