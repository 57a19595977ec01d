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
from . import checkpoint, parallel
from .checkpoint import Checkpoint
from .contact import BodyContact
from .dem import DemMpmPair, calibrate as calibrateDem, uniaxialTension
from .engines import MpmEngine, VelocityBC, callEvery, criticalTimeStep, findEngine, mpmEngines
from .fracture import EigenErosion, kappaRange
from .materials import ElasticMaterial
from .recorders import PlotRecorder, Progress, VTKRecorder

__all__ = ["MpmEngine", "EigenErosion", "kappaRange", "VelocityBC", "ElasticMaterial", "VTKRecorder",
           "PlotRecorder", "Progress", "callEvery", "criticalTimeStep", "findEngine", "mpmEngines",
           "DemMpmPair", "calibrateDem", "uniaxialTension", "Checkpoint", "BodyContact"]

from . import state as _state  # noqa: E402

_state.install()  # O.save/O.load and O.saveTmp/O.loadTmp carry the EigenMPM state

from .cli import installInterruptibleRun as _installInterruptibleRun  # noqa: E402

_installInterruptibleRun()  # Ctrl-C stops O.run(n, True) at a step boundary in any script
