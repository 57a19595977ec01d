"""DEM fracture beside EigenMPM in one YADE run: the same specimen, material and loading,
modelled by YADE's discrete elements (CPM, or JCFpm) and by the material point method.

    import eigenmpm as em
    pair = em.DemMpmPair(specimen, E=30e9, nu=0.2, rho=2400, Gc=100, ft=3e6, h=0.01,
                         radius=0.005, thickness=0.05)
    pair.notch([(0.225, -0.01, 0), (0.225, 0.05, 0)])
    pair.fix('left', points=..., components='y')
    load = pair.velocityBC('load', points=..., components='y', velocity=(0, -0.02, 0))
    O.engines = pair.engines() + [em.callEvery(pair.record, iterPeriod=10)]
    pair.setTimeStep(0.8)            # one O.dt below both critical steps
    O.run(5000, True)
    pair.summary()

By concern:

- ``calibration``: DEM micro-parameters from the continuum constants (:func:`calibrate`, the
  rule) and their correction by measurement (:func:`calibrateMeasured`, :func:`measure`);
- ``specimen``: the slab of spheres on an hcp lattice (:func:`hcpCenters`, :func:`layersFor`,
  :class:`DemSpecimen`), its velocity conditions (:class:`DemBC`), bonds, damage and dissipated
  energy (``DemSpecimen.bondState``, :func:`cpmBondEnergy`);
- ``pair``: one specimen as an EigenMPM body and a DEM slab in one scene (:class:`DemMpmPair`)
  and the run of the comparison examples (:func:`runToDisplacement`);
- ``labtests``: tests of the DEM alone (:func:`uniaxialTension`; it resets the scene);
- ``reports``: summary.json, load-displacement curves and crack patterns of a pair.
"""
from .calibration import ALPHA_MAX, NU_FIT, calibrate, calibrateMeasured, measure, modulusFactor, stiffnessRatio
from .labtests import uniaxialTension
from .pair import DemMpmPair, resumePair, runToDisplacement
from .reports import crackPatterns, report, smoothed
from .specimen import (HCP_CONTACTS, HCP_FRACTION, LAYER, MODELS, DemBC, DemSpecimen, cpmBondEnergy, hcpCenters,
                       layersFor)

__all__ = ["ALPHA_MAX", "MODELS", "NU_FIT", "calibrate", "calibrateMeasured", "measure", "modulusFactor",
           "stiffnessRatio", "uniaxialTension", "DemMpmPair", "resumePair", "runToDisplacement", "crackPatterns", "report",
           "smoothed", "HCP_CONTACTS", "HCP_FRACTION", "LAYER", "DemBC", "DemSpecimen", "cpmBondEnergy",
           "hcpCenters", "layersFor"]
