"""EigenMPM: dynamic brittle fracture in continua for YADE: the material point method on a
GIMP grid, eigenerosion for crack growth (EigenErosion) and phantom nodes for pre-existing
cracks (MpmEngine.crack).

Put the engines in ``O.engines`` beside YADE's own::

    import eigenmpm as em
    mpm = em.MpmEngine(dim=2, h=0.01)
    ...
    O.engines = [mpm, em.VTKRecorder(fileName='out/bar-', iterPeriod=100),
                 em.PlotRecorder(iterPeriod=10), em.Progress(endIter=10000)]
"""
from ._isa import load as _loadModule

# The compiled module for this processor (x86-64 or x86-64-v2, bitwise the same results), before
# any other part of the package imports it; `isa` says which.
_eigenmpm, isa = _loadModule()
# The vector width of the lane loops (pkg/Lanes.hpp), the processor's widest unless
# EIGENMPM_LANES caps it: the same results in every width.
laneIsa, setLaneIsa = _eigenmpm.laneIsa, _eigenmpm.setLaneIsa

from . import checkpoint, parallel  # noqa: E402
from .checkpoint import Checkpoint  # noqa: E402
from .contact import BodyContact  # noqa: E402
from .dem import DemMpmPair, calibrate as calibrateDem, uniaxialTension  # noqa: E402
from .engines import MpmEngine, VelocityBC, callEvery, criticalTimeStep, findEngine, mpmEngines  # noqa: E402
from .fracture import EigenErosion, kappaRange  # noqa: E402
from .materials import ElasticMaterial  # noqa: E402
from .recorders import PlotRecorder, Progress, VTKRecorder  # noqa: E402

__all__ = ["MpmEngine", "EigenErosion", "kappaRange", "VelocityBC", "ElasticMaterial", "VTKRecorder",
           "PlotRecorder", "Progress", "callEvery", "criticalTimeStep", "findEngine", "mpmEngines",
           "DemMpmPair", "calibrateDem", "uniaxialTension", "Checkpoint", "BodyContact"]

from . import state as _state  # noqa: E402

_state.install()  # O.save/O.load and O.saveTmp/O.loadTmp carry the EigenMPM state

from .cli import installInterruptibleRun as _installInterruptibleRun  # noqa: E402

_installInterruptibleRun()  # Ctrl-C stops O.run(n, True) at a step boundary in any script

from .engines import watchEngines as _watchEngines  # noqa: E402

_watchEngines()  # (last: around the wrappers above) every change of the scene's engines is counted

from .contact import watchBodies as _watchBodies  # noqa: E402

_watchBodies()  # every Python change of O.bodies that erases, replaces or regroups bodies is counted
