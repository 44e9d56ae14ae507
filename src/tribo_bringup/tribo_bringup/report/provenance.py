"""Provenance of a report: command line, versions, git commit, platform, time.

The commit comes from ``git`` itself (``git rev-parse HEAD`` and
``git status --porcelain`` with a timeout); without git, or outside a
repository, it is None.
"""

from __future__ import annotations

import platform
import shlex
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TypedDict

#: The workspace's packages whose package.xml versions are recorded.
PACKAGES = (
    'tribo_bringup',
    'tribo_common',
    'tribo_msgs',
    'tribo_drivers',
    'tribo_estimation',
    'tribo_nvct',
)

#: Third-party packages whose versions are recorded.
THIRD_PARTY = ('numpy', 'scipy', 'numba', 'rosbags', 'matplotlib', 'foxglove-sdk')

#: Longest wait for one git call [s].
GIT_TIMEOUT_S = 5.0


def _version(module: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(module)
    except PackageNotFoundError:
        return 'not installed'


def _package_xml_version(pkg: str, root: Path) -> str:
    xml = root / 'src' / pkg / 'package.xml'
    try:
        text = xml.read_text(encoding='utf-8')
        return text.split('<version>')[1].split('</version>')[0].strip()
    except (OSError, IndexError):
        return 'unknown'


def _git(root: Path, *args: str) -> str | None:
    """Output of ``git -C root args`` (stripped), or None when git fails or is absent."""
    try:
        proc = subprocess.run(
            ['git', '-C', str(root), *args],
            capture_output=True,
            text=True,
            timeout=GIT_TIMEOUT_S,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return proc.stdout.strip() if proc.returncode == 0 else None


def git_state(root: Path) -> tuple[str | None, bool | None]:
    """Return (commit of HEAD, whether the working tree has uncommitted changes).

    For the repository at ``root``; (None, None) without git or outside a
    repository.
    """
    commit = _git(root, 'rev-parse', 'HEAD')
    if not commit:
        return None, None
    status = _git(root, 'status', '--porcelain', '--untracked-files=no')
    return commit, (bool(status) if status is not None else None)


class Provenance(TypedDict):
    """What produced a report (results.json ``provenance``; shown at the page's end)."""

    command: str
    versions: dict[str, str]
    git_commit: str | None
    git_dirty: bool | None
    platform: str
    created: str


def provenance(command: Sequence[str] | None, root: Path | None = None) -> Provenance:
    """Collect the command line, versions and git commit that produced a report.

    ``command``: the command line to record (default ``sys.argv``); ``root``: the
    workspace (default: the source tree this module lives in).
    """
    root = root if root is not None else Path(__file__).resolve().parents[4]
    versions = {'python': platform.python_version()}
    versions.update({m: _version(m) for m in THIRD_PARTY})
    versions.update({p: _package_xml_version(p, root) for p in PACKAGES})
    commit, dirty = git_state(root)
    return {
        'command': shlex.join(command if command is not None else sys.argv),
        'versions': versions,
        'git_commit': commit,
        'git_dirty': dirty,
        'platform': platform.platform(),
        'created': time.strftime('%Y-%m-%d %H:%M:%S %z'),
    }
