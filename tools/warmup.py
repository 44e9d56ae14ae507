"""Compile (and cache) the numba kernels once, so the first node or test does not wait.

Run by `make setup` after the build; safe to run any time.
"""

from __future__ import annotations

import sys
import time


def main() -> int:
    """Call each jitted entry point once on a small problem."""
    t0 = time.monotonic()
    try:
        from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
        from tribo_estimation.core.simulate import simulate
    except ImportError as exc:  # the core is not there: nothing to warm
        print(f'warmup: skipped ({exc})', file=sys.stderr)
        return 0
    simulate(RigParams.tab1(), FrictionLaw(0.13, 0.10), DriveProfile(3.0, 0.1), 0.01)
    print(f'warmup: numba kernels ready in {time.monotonic() - t0:.1f} s', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
