"""Rewrite build-machine paths in the ROS 2 wheels' CMake export files.

The ros-jazzy-* wheels on PyPI were built under ``/opt/python/cp311-cp311``;
their ``*Export.cmake`` files name that interpreter's include directories,
which do not exist here. This script rewrites them, inside the project's
virtual environment only, to this interpreter's include directory and this
environment's numpy include directory. It is idempotent.

Usage: ``.venv/bin/python tools/fix_ros_wheels.py``
"""

from __future__ import annotations

import sys
import sysconfig
from pathlib import Path

BUILD_PREFIX = '/opt/python/cp311-cp311'


def main() -> int:
    """Rewrite the paths; print how many files changed."""
    import numpy

    venv = Path(sys.prefix)
    if venv == Path(sys.base_prefix):
        print('fix_ros_wheels: refusing to run outside a virtual environment', file=sys.stderr)
        return 2
    py_include = sysconfig.get_paths()['include']
    np_include = numpy.get_include()
    site = sysconfig.get_paths()['purelib']
    replacements = (
        (f'{BUILD_PREFIX}/lib/python3.11/site-packages/numpy/_core/include', np_include),
        (f'{BUILD_PREFIX}/include/python3.11', py_include),
        (f'{BUILD_PREFIX}/lib/python3.11/site-packages', site),
    )
    changed = 0
    for path in (venv / 'share').rglob('*.cmake'):
        text = path.read_text(encoding='utf-8', errors='surrogateescape')
        if BUILD_PREFIX not in text:
            continue
        for old, new in replacements:
            text = text.replace(old, new)
        path.write_text(text, encoding='utf-8', errors='surrogateescape')
        changed += 1
    print(f'fix_ros_wheels: rewrote {changed} CMake export file(s) in {venv}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
