"""Where the project's configuration examples live (``config/`` of the workspace).

``TRIBO_CONFIG_DIR`` overrides; else ``$TRIBO_ROOT/config`` (set by env.sh); else
the ``config/`` beside this source tree; else the copy installed into
``share/tribo_bringup/config`` (an install without the workspace sources).
"""

from __future__ import annotations

import os
from pathlib import Path


def config_dir() -> Path:
    """Return the configuration directory (``TRIBO_CONFIG_DIR``, ``TRIBO_ROOT``/config, ...)."""
    if os.environ.get('TRIBO_CONFIG_DIR'):
        return Path(os.environ['TRIBO_CONFIG_DIR'])
    if os.environ.get('TRIBO_ROOT'):
        return Path(os.environ['TRIBO_ROOT']) / 'config'
    source_tree = Path(__file__).resolve().parents[3] / 'config'
    if source_tree.is_dir():
        return source_tree
    try:
        from ament_index_python.packages import get_package_share_directory

        return Path(get_package_share_directory('tribo_bringup')) / 'config'
    except (ImportError, LookupError):
        return source_tree


CONFIG = config_dir()
