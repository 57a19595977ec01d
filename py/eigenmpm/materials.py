"""Continuum materials of EigenMPM."""
import math
import sys

from . import _eigenmpm
from .params import Param, apply, declare


@declare
class ElasticMaterial:
    """Isotropic linear elastic material with a tension/compression split of its strain energy:
    the paper's spectral split (Eqs 2-7) by default, or another registered law (``split``).
    In 2D it is plane strain unless ``planeStress`` is set. A material is a value: its
    parameters are fixed once it is built, and E and rho must give a finite, non-zero wave speed
    (the critical time step is the cell size over it).

    Example::

        glass = eigenmpm.ElasticMaterial(E=72e9, nu=0.22, rho=2440, planeStress=True)
    """

    params = (
        Param("E", None, "Pa", "Young's modulus", kind="float", bounds="(0, inf)", required=True, fixed=True),
        Param("nu", 0.0, "", "Poisson's ratio", bounds="(-1, 0.5)", fixed=True),
        Param("rho", None, "kg/m3", "mass density", kind="float", bounds="(0, inf)", required=True, fixed=True),
        Param("planeStress", False, "", "2D only: plane stress instead of plane strain (refused by a 3D "
                                        "MpmEngine)", fixed=True),
        Param("split", "spectral", "", "tension/compression split of the strain energy (which part "
                                       "drives fracture), one of the laws registered in pkg/Laws.hpp; "
                                       "'spectral' is the paper's (Eqs 2-7); see doc/fracture.md",
              choices=tuple(_eigenmpm.lawNames()), fixed=True),
    )

    def __init__(self, **kw):
        apply(self, self.params, kw, "ElasticMaterial")
        self._checkWaveSpeed()

    def _checkWaveSpeed(self):
        """The P-wave modulus M = E (1 - nu) / ((1 + nu) (1 - 2 nu)) (plane strain and 3D, the
        stiffest case) and the wave speed sqrt(M / rho) must be finite and > 0; otherwise the
        critical time step would be 0 or infinite at any cell size, and the run would fail later."""
        E, nu, rho, big = self.E, self.nu, self.rho, sys.float_info.max
        factor = (1 - nu) / ((1 + nu) * (1 - 2 * nu))
        M = E * factor
        if not math.isfinite(M):
            raise ValueError(f"EigenMPM: E = {E!r} is invalid with nu = {nu!r}: the P-wave modulus "
                             f"E (1 - nu) / ((1 + nu) (1 - 2 nu)) overflows, so the critical time step would be 0; "
                             f"allowed: E < {big / factor:.4g} Pa for this nu (ElasticMaterial)")
        c2 = M / rho
        if not math.isfinite(c2):
            raise ValueError(f"EigenMPM: rho = {rho!r} is invalid with E = {E!r} and nu = {nu!r}: the wave speed "
                             f"sqrt(M / rho) overflows, so the critical time step would be 0; allowed: "
                             f"rho > {M / big:.4g} kg/m3 for this E (ElasticMaterial)")
        if not c2 > 0:
            raise ValueError(f"EigenMPM: E = {E!r} is invalid with rho = {rho!r}: the wave speed sqrt(M / rho) is 0 "
                             "(underflow), so the critical time step would be infinite; allowed: E / rho > "
                             f"{sys.float_info.min:.4g} m2/s2 (ElasticMaterial)")

    def __repr__(self):
        return f"ElasticMaterial({', '.join(f'{p.name}={getattr(self, p.name)!r}' for p in self.params)})"
