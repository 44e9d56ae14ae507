"""The missing-physics pipeline: prepare -> baseline -> screen -> decide.

One pipeline for one record, several records (fitted jointly) and the live monitor's
window; they differ only in their budget (:class:`.policy.Policy`). Modules:
:mod:`.policy` (rules and budget), :mod:`.prepare` (instrument chain, segments,
drive profile, baseline), :mod:`.ensemble` (the records as one model), :mod:`.noise`
(the measured noise), :mod:`.null` (adequacy statistics and their null law by a
parametric bootstrap), :mod:`.screen` (every form of every family),
:mod:`.decide` (the rules), :mod:`.result` and :mod:`.run`
(:func:`find_missing_physics`).
"""

from .decide import KINDS
from .policy import Policy
from .result import Effect, MissingPhysics, RecordReport
from .run import find_missing_physics

__all__ = ['KINDS', 'Effect', 'MissingPhysics', 'Policy', 'RecordReport', 'find_missing_physics']
