"""Continuum materials of EigenMPM."""
from . import _eigenmpm
from .params import Param, apply, declare


@declare
class ElasticMaterial:
    """Isotropic linear elastic material with a tension/compression split of its strain energy:
    the paper's spectral split (Eqs 2-7) by default, or the volumetric-deviatoric split, or none.
    In 2D it is plane strain unless ``planeStress`` is set.

    Example::

        glass = eigenmpm.ElasticMaterial(E=72e9, nu=0.22, rho=2440, planeStress=True)
    """

    params = (
        Param("E", None, "Pa", "Young's modulus; E > 0"),
        Param("nu", 0.0, "", "Poisson's ratio; -1 < nu < 0.5"),
        Param("rho", None, "kg/m3", "mass density; rho > 0"),
        Param("planeStress", False, "", "2D only: plane stress instead of plane strain"),
        Param("split", "spectral", "", "tension/compression split of the strain energy (which part "
                                       "drives fracture): 'spectral' (the paper's, Eqs 2-7), "
                                       "'volumetric' (Amor et al. 2009) or 'none'; see doc/fracture.md"),
    )

    def __init__(self, **kw):
        apply(self, self.params, kw, "ElasticMaterial")
        for name in ("E", "rho"):
            if getattr(self, name) is None:
                raise TypeError(f"ElasticMaterial: parameter {name} is required")
        _eigenmpm.checkElasticMaterial(float(self.E), float(self.nu), float(self.rho), bool(self.planeStress),
                                       str(self.split))

    def __repr__(self):
        return (f"ElasticMaterial(E={self.E!r}, nu={self.nu!r}, rho={self.rho!r}, "
                f"planeStress={self.planeStress!r}, split={self.split!r})")
