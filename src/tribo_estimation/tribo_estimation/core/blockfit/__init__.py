"""Block-wise identification of the friction law (paper section 2.5, Fig. 4/5).

The measured record is cut into blocks of ``block_length`` seconds (1 s in the
paper). For each block the friction law of Equ. 8,
``mu(|v|) = (mu0 - mu_inf)*exp(-k*|v|) + mu_inf`` (with the paper's
deceleration rule), is identified from the torsion moment ``C1*phi1`` [N m] and
the chamber acceleration ``w1'`` [rad/s^2] with the rig model of Equ. 1-3 and 6.

One job per module:

- :mod:`.results`: settings and result types (:class:`BlockConfig`,
  :class:`BlockResult`, :data:`FLAGS`, :class:`BlockData`, :class:`FitOutcome`,
  :class:`PendingBlock`, :class:`BlockDetail`).
- :mod:`.csvio`: the ``blocks.csv`` table (:data:`CSV_COLUMNS`,
  :data:`FILE_COLUMNS`, :class:`BlockCsvWriter`, :func:`read_blocks_csv`,
  :func:`results_table`).
- :mod:`.fit`: the output-error (multiple-shooting) fit of one block
  (:func:`initial_estimate`, :func:`initial_k`, :func:`fit_block`).
- :mod:`.evaluate`: one block's checks, stick detection, fit and quality flags
  (:func:`evaluate_block`, :func:`is_saturated`, :data:`MIN_BREAKAWAYS`).
- :mod:`.streaming`: blocks from an aligned stream (:class:`BlockEstimator`) and the
  live pipeline (:class:`StreamingPipeline`, :class:`MomentChunk`).

Every value is in SI units: moments N m, speeds rad/s, accelerations rad/s^2,
time s, coefficients dimensionless, k in s/rad.
"""

from __future__ import annotations

from ...errors import FitError
from .csvio import (
    CSV_COLUMNS,
    FILE_COLUMNS,
    REQUIRED_COLUMNS,
    BlockCsvWriter,
    block_row,
    read_blocks_csv,
    results_table,
)
from .evaluate import MIN_BREAKAWAYS, evaluate_block, is_saturated
from .fit import fit_block, initial_estimate, initial_k
from .results import (
    FLAGS,
    MOTIONS,
    BlockConfig,
    BlockData,
    BlockDetail,
    BlockResult,
    FitOutcome,
    PendingBlock,
    with_flags,
)
from .streaming import BlockEstimator, MomentChunk, StreamingPipeline

__all__ = [
    'CSV_COLUMNS',
    'FILE_COLUMNS',
    'FLAGS',
    'MIN_BREAKAWAYS',
    'MOTIONS',
    'REQUIRED_COLUMNS',
    'BlockConfig',
    'BlockCsvWriter',
    'BlockData',
    'BlockDetail',
    'BlockEstimator',
    'BlockResult',
    'FitError',
    'FitOutcome',
    'MomentChunk',
    'PendingBlock',
    'StreamingPipeline',
    'block_row',
    'evaluate_block',
    'fit_block',
    'initial_estimate',
    'initial_k',
    'is_saturated',
    'read_blocks_csv',
    'results_table',
    'with_flags',
]
