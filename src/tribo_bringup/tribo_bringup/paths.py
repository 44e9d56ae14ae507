"""Where the project's configuration examples live (``config/`` of the workspace).

``TRIBO_CONFIG_DIR`` overrides; else ``$TRIBO_ROOT/config`` (set by env.sh); else
the ``config/`` beside this source tree.
"""

from __future__ import annotations

import os
from pathlib import Path


def config_dir() -> Path:
    """The configuration directory."""
    if os.environ.get('TRIBO_CONFIG_DIR'):
        return Path(os.environ['TRIBO_CONFIG_DIR'])
    if os.environ.get('TRIBO_ROOT'):
        return Path(os.environ['TRIBO_ROOT']) / 'config'
    return Path(__file__).resolve().parents[3] / 'config'


CONFIG = config_dir()
