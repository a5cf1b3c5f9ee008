"""The quasi-static evolution engine, shared by every model.

* :mod:`thinfilm.engine.protocol`: what a model offers (:class:`FractureModel`) and its
  optional hooks;
* :mod:`thinfilm.engine.options`: the options of each part, declared once;
* :mod:`thinfilm.engine.evolution`: :class:`Engine` (alternate minimization, over-relaxation,
  backtracking, nucleation search, stability check);
* :mod:`thinfilm.engine.records`: what it returns.
"""

from thinfilm.engine.evolution import Engine, EvolutionError
from thinfilm.engine.options import (AltMinOptions, BacktrackOptions, EngineOptions, SearchOptions,
                                     StabilityOptions)
from thinfilm.engine.protocol import DamageProjection, FractureModel, StabilityModes, TrialStates
from thinfilm.engine.records import State, StepRecord

__all__ = ["Engine", "EvolutionError", "AltMinOptions", "BacktrackOptions", "EngineOptions", "SearchOptions",
           "StabilityOptions", "FractureModel", "TrialStates", "StabilityModes", "DamageProjection", "State",
           "StepRecord"]
