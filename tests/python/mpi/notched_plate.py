"""A notched glass plate under tractions, with eigenerosion, run the same way on one process
and under mpiexec (tests/python/test_mpi.py): every rank writes its points by id to
OUT/rank-R.npz and rank 0 the engine's totals to OUT/summary.json; a VTKRecorder writes
OUT/vtk/plate-*.vtp (under mpiexec: a piece per rank and a .pvtp).

    [mpiexec -n N] yade -n -x tests/python/mpi/notched_plate.py OUT [steps] [held] [cols=C]

`held`: the engine distributes its points at set-up (MpmEngine(distributedSetup=True)).
`cols=C`: columns of 2 cells (MpmEngine(columnCells=2)) and, under mpiexec, C columns of ranks
(rankColumns=C): a decomposition in two directions (doc/parallel.md).
"""
import json
import os
import sys

import numpy as np
from yade import O, pack

import eigenmpm as em

out = sys.argv[1]
steps = int(sys.argv[2]) if len(sys.argv) > 2 else 300
held = "held" in sys.argv[3:]
cols = [int(a[5:]) for a in sys.argv[3:] if a.startswith("cols=")]
os.makedirs(out, exist_ok=True)
h = 1e-3
mpm = em.MpmEngine(dim=2, h=h, thickness=h, label="plate", domain=((-0.003, -0.003, 0), (0.027, 0.027, 0)),
                   distributedSetup=held, columnCells=2 if cols else 0, rankColumns=cols[0] if cols else 1)
glass = em.ElasticMaterial(E=72e9, nu=0.22, rho=2440, planeStress=True)
mpm.fill(pack.inAlignedBox((0, 0, -1), (0.024, 0.024, 1)) - pack.inAlignedBox((-1, 0.0115, -1), (0.008, 0.0125, 1)), glass)
mpm.traction(points=pack.inAlignedBox((-1, 0.023, -1), (1, 1, 1)), traction=(0, 12e6, 0))
mpm.traction(points=pack.inAlignedBox((-1, -1, -1), (1, 0.001, 1)), traction=(0, -12e6, 0))
mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (0, 1, 1)), components="x", label="left")
crack = em.EigenErosion(engine=mpm, Gc=30.0, alpha=2.0, kappaOverH=1.1, origin=(0.008, 0.012, 0))
vtk = em.VTKRecorder(engine=mpm, fileName=os.path.join(out, "vtk", "plate-"), iterPeriod=150)
O.engines = [mpm, crack, vtk]
O.dt = 0.5 * mpm.criticalTimeStep()
setup = em.parallel.allCounts(len(mpm.solver.positions()))  # each rank's points before the first step
O.run(steps, True)
vtk.finalRecord()
s = mpm.solver
np.savez(os.path.join(out, f"rank-{em.parallel.rank()}.npz"), ids=s.globalIds(), x=s.positions(), v=s.velocities(),
         stress=s.stress(), damage=s.damage())
summary = {"ranks": s.ranks, "rankColumns": s.rankColumns, "points": mpm.numPoints(), "setup": setup, "held": mpm.referencePositions is None, "eroded": crack.erodedCount(), "dissipated": crack.dissipatedEnergy(),
           "kinetic": mpm.kineticEnergy(), "elastic": mpm.elasticEnergy(), "work": mpm.externalWork(),
           "reaction": list(s.reaction(0)), "front": crack.frontDistance(),
           "x": em.parallel.gather(mpm, s.positions()).tolist()[:5]}
if em.parallel.isRoot():
    with open(os.path.join(out, "summary.json"), "w") as f:
        json.dump(summary, f)
