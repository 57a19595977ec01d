"""Continuum materials of EigenMPM."""
from . import _eigenmpm
from .params import Param, apply, declare


@declare
class ElasticMaterial:
    """Isotropic linear elastic material with a tension/compression split of its strain energy:
    the paper's spectral split (Eqs 2-7) by default, or another registered law (``split``).
    In 2D it is plane strain unless ``planeStress`` is set.

    Example::

        glass = eigenmpm.ElasticMaterial(E=72e9, nu=0.22, rho=2440, planeStress=True)
    """

    params = (
        Param("E", None, "Pa", "Young's modulus", kind="float", bounds="(0, inf)", required=True),
        Param("nu", 0.0, "", "Poisson's ratio", bounds="(-1, 0.5)"),
        Param("rho", None, "kg/m3", "mass density", kind="float", bounds="(0, inf)", required=True),
        Param("planeStress", False, "", "2D only: plane stress instead of plane strain"),
        Param("split", "spectral", "", "tension/compression split of the strain energy (which part "
                                       "drives fracture), one of the laws registered in pkg/Laws.hpp; "
                                       "'spectral' is the paper's (Eqs 2-7); see doc/fracture.md",
              choices=tuple(_eigenmpm.lawNames())),
    )

    def __init__(self, **kw):
        apply(self, self.params, kw, "ElasticMaterial")

    def __repr__(self):
        return f"ElasticMaterial({', '.join(f'{p.name}={getattr(self, p.name)!r}' for p in self.params)})"
