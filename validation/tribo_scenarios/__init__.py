"""Independent scenario generator for validating the missing-physics workflow.

Draws rig records from a documented wide space (:mod:`.space`) and simulates them
with its own equations, integrator, drive profiles and instrument models; it
imports nothing from the ``tribo_*`` packages, so a record it makes shares no code
with the fits that analyse it.

    spec = draw(seed)            # the specification only (cheap)
    sc = generate(spec)          # the measured record with its truth (cached)
    sc.write_dir('out/')         # record.csv, rig.yaml, truth.json

``python -m tribo_scenarios SEED --out DIR`` does the last two steps.
"""

from .errors import CacheError, InvalidRequestError, OutputError, ScenarioError, SimulationError
from .generate import DEFAULT_RTOL, default_cache_dir, generate, simulate_truth
from .scenario import Scenario, Truth
from .space import DRIVE_KINDS, LIBRARY_FORMS, OUTSIDE_FORMS, SAMPLE_RATES, draw
from .spec import GENERATOR_VERSION, EffectSpec, ScenarioSpec

__all__ = [
    'DEFAULT_RTOL',
    'DRIVE_KINDS',
    'GENERATOR_VERSION',
    'LIBRARY_FORMS',
    'OUTSIDE_FORMS',
    'SAMPLE_RATES',
    'CacheError',
    'EffectSpec',
    'InvalidRequestError',
    'OutputError',
    'Scenario',
    'ScenarioError',
    'ScenarioSpec',
    'SimulationError',
    'Truth',
    'default_cache_dir',
    'draw',
    'generate',
    'simulate_truth',
]
