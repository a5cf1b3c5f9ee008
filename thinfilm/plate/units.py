"""Physical units: a film's material and geometry -> the non-dimensional groups (2.13).

The solver works with the non-dimensional energy of ``docs/model.md`` (lengths in units of ``L``), whose
parameters are ``winkler = K~ / a^4`` and ``toughness = G~ / a`` with

    K~ = 12 K_b h (1 - nu^2) / E,    G~ = 12 Gc (1 - nu^2) / (E h),    a = h / L,

from Young's modulus ``E``, Poisson's ratio ``nu``, film thickness ``h``, fracture toughness
``Gc`` (or ``K_IC``, with ``Gc = K_IC^2 / E``, plane stress), the bond (Winkler foundation)
stiffness ``K_b`` per unit area, and the length ``L`` that the domain's coordinates are
measured in. The flexural rigidity is ``D = E h^3 / (12 (1 - nu^2))``.

Lengths and deflections are both scaled by ``L`` (the dissertation's ``x0 = u0 = L``) and
the energy by ``D``: a non-dimensional energy ``E~`` is ``D E~`` joules, a force conjugate to
a displacement (in units of L) ``D / L`` newtons (:meth:`Material.force_unit`). A 1D film's
energy is per unit width (the width in units of L): ``D / L`` J/m, forces ``D / L^2`` N/m.

For the ITO film of the dissertation's Table 2.1 (E = 99.8 GPa, K_IC = 2.2 MPa sqrt(m),
h = 0.1 um, nu = 0.3), (2.13) gives G~ = 0.053, ten times the printed 5e-3 (``docs/model.md#physical-units``);
``cases/ito_indentation.toml`` uses the formula.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Material:
    """A film bonded to a substrate, in SI units.

    Attributes
    ----------
    E : float
        Young's modulus of the film (Pa).
    nu : float
        Poisson's ratio of the film.
    h : float
        Film thickness (m).
    Gc : float
        Fracture toughness, energy per unit crack area (J/m^2).
    bond_stiffness : float
        Winkler foundation stiffness ``K_b``: traction per unit deflection (Pa/m).
    L : float
        Unit of length of the domain's coordinates (m).
    """

    E: float
    nu: float
    h: float
    Gc: float
    bond_stiffness: float
    L: float

    @property
    def a(self):
        """Aspect ratio ``h / L``."""
        return self.h / self.L

    @property
    def K_tilde(self):
        """``12 K_b h (1 - nu^2) / E``."""
        return 12.0 * self.bond_stiffness * self.h * (1.0 - self.nu**2) / self.E

    @property
    def G_tilde(self):
        """``12 Gc (1 - nu^2) / (E h)``."""
        return 12.0 * self.Gc * (1.0 - self.nu**2) / (self.E * self.h)

    @property
    def winkler(self):
        """Non-dimensional foundation stiffness ``K~ / a^4``."""
        return self.K_tilde / self.a**4

    @property
    def toughness(self):
        """Non-dimensional toughness ``G~ / a``."""
        return self.G_tilde / self.a

    @property
    def rigidity(self):
        """Flexural rigidity ``D = E h^3 / (12 (1 - nu^2))`` (N m)."""
        return self.E * self.h**3 / (12.0 * (1.0 - self.nu**2))

    def energy_unit(self, dim=2):
        """The physical energy of a unit of non-dimensional energy: ``D`` (J) for a 2D film,
        ``D / L`` (J per metre of width) for a 1D film."""
        return self.rigidity if dim == 2 else self.rigidity / self.L

    def force_unit(self, dim=2):
        """The physical force of a unit of non-dimensional force (energy per displacement, both
        non-dimensional): ``D / L`` (N) for a 2D film, ``D / L^2`` (N per metre of width) for a
        1D film."""
        return self.energy_unit(dim) / self.L

    def groups(self):
        """The non-dimensional groups and derived quantities, for logs and results.

        Returns
        -------
        dict of str to float
            ``K_tilde``, ``G_tilde``, ``a``, ``winkler``, ``toughness``, ``lam``
            (``winkler^(1/4) / sqrt(2)``), ``rigidity`` (N m).
        """
        return {"K_tilde": self.K_tilde, "G_tilde": self.G_tilde, "a": self.a, "winkler": self.winkler,
                "toughness": self.toughness, "lam": self.winkler**0.25 / math.sqrt(2.0),
                "rigidity": self.rigidity}


def stored_material(attrs):
    """The :class:`Material` of a results file's ``/material`` attributes (its fields are
    among them, beside the derived groups)."""
    return Material(**{f.name: float(attrs[f.name]) for f in dataclasses.fields(Material)})


def physical_scales(material, dim):
    """The SI value of one non-dimensional unit of length, energy and force.

    Parameters
    ----------
    material : Material
    dim : {1, 2}
        The film's dimension: a 1D film's energies and forces are per metre of width.

    Returns
    -------
    dict
        ``length`` (m per L), ``energy`` (J, or J/m in 1D, per unit:
        :meth:`Material.energy_unit`), ``force`` (N, or N/m: :meth:`Material.force_unit`), and
        their unit names ``length_unit``, ``energy_unit``, ``force_unit``.
    """
    return {"length": material.L, "energy": material.energy_unit(dim), "force": material.force_unit(dim),
            "length_unit": "m", "energy_unit": "J" if dim == 2 else "J/m", "force_unit": "N" if dim == 2 else "N/m"}


def file_scales(file):
    """:func:`physical_scales` of an open plate results file (an ``h5py.File``) whose scene had a
    ``[material]``; None without one."""
    if "material" not in file:
        return None
    return physical_scales(stored_material(file["material"].attrs), int(file["grid"].attrs["dim"]))


def toughness_from_KIC(K_IC, E):
    """``Gc = K_IC^2 / E`` (plane stress), J/m^2 from Pa sqrt(m) and Pa."""
    return K_IC**2 / E
