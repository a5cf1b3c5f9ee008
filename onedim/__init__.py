"""Exact solutions of the one-dimensional thin-film fracture problem under pure bending.

A film on (-l0/2, l0/2) bonded to a Winkler foundation, loaded by the substrate
displacement ``w_t(x) = -t x^2 / 2``, with sharp cracks that cost ``G/a`` each.
The elastic energy of a fragment has a closed form (:mod:`onedim.fragment`), so the
energy of any partition is known exactly (:mod:`onedim.partition`) and the global
minimizer over partitions on a grid is found by dynamic programming
(:mod:`onedim.dynprog`, :mod:`onedim.evolution`).
"""

from onedim.fragment import (
    scaling_F,
    fragment_coefficient,
    fragment_energy,
    fragment_energy_derivative_F,
    scaling_F_second_derivative,
    fragment_displacement,
    lam_from_winkler,
    winkler_from_lam,
)
from onedim.partition import partition_energy, partition_elastic_coefficient
from onedim.evolution import Evolution, Event, evolve

__all__ = [
    "scaling_F",
    "fragment_coefficient",
    "fragment_energy",
    "fragment_energy_derivative_F",
    "scaling_F_second_derivative",
    "fragment_displacement",
    "lam_from_winkler",
    "winkler_from_lam",
    "partition_energy",
    "partition_elastic_coefficient",
    "Evolution",
    "Event",
    "evolve",
]
