"""O.save and O.load under mpiexec (doc/parallel.md): `save` builds the quick crack-branching plate
of examples/crack_branching.py, runs `steps`, saves the scene (rank 0 the .yade file, every rank
its part beside it), runs `steps` more and writes every rank's points to OUT/full-rR.npz; `resume`
loads the scene, runs `steps` and writes OUT/resumed-rR.npz (tests/python/test_mpi.py).

    mpiexec -n N yade -n -j1 -x tests/python/mpi/save_resume.py save|resume OUT [steps]
"""
import os
import sys

import numpy as np
from yade import O

import eigenmpm as em

sys.path.insert(0, os.path.join(os.path.dirname(os.path.realpath(em.__file__)), "..", "..", "examples"))
import crack_branching  # noqa: E402

phase, out = sys.argv[1], sys.argv[2]
steps = int(sys.argv[3]) if len(sys.argv) > 3 else 300
os.makedirs(out, exist_ok=True)
scene = os.path.join(out, "scene.yade")
if phase == "save":
    o = dict(crack_branching.DEFAULTS)
    o.update(crack_branching.QUICK)
    mpm, crack = crack_branching.build(o)
    O.engines = [mpm, crack]
    O.dt = o["dt_us"] * 1e-6
    O.run(steps, True)
    O.save(scene)
else:
    O.load(scene)
    mpm = em.findEngine("plate")
O.run(steps, True)
s = mpm.solver
np.savez(os.path.join(out, f"{'full' if phase == 'save' else 'resumed'}-r{em.parallel.rank()}.npz"),
         ids=s.globalIds(), x=s.positions(), v=s.velocities(), stress=s.stress(), damage=s.damage(),
         eroded=[em.findEngine("plate").physics and list(mpm.physics.values())[0].erodedCount()])
