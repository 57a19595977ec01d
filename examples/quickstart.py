"""Quick start from the README: a plane-stress concrete bar fixed at x = 0 and pulled at x = 0.5 m.

    yade -n -x examples/quickstart.py

Writes out/bar-*.vtp, out/bar-series.pvd and out/energy.png.
"""
from yade import O, pack, plot
import eigenmpm as em

mpm = em.MpmEngine(dim=2, h=0.005, ppc=2, shape='uGIMP', thickness=0.1, label='mpm')
concrete = em.ElasticMaterial(E=30e9, nu=0.2, rho=2400, planeStress=True)
mpm.fill(pack.inAlignedBox((0, 0, 0), (0.5, 0.1, 0)), concrete)          # any yade.pack predicate
support = mpm.fix(region=pack.inAlignedBox((-1, -1, -1), (0.0, 1, 1)), label='support')
mpm.velocityBC(points=pack.inAlignedBox((0.495, -1, -1), (1, 1, 1)), components='x',
               velocity=(0.01, 0, 0), rampTime=1e-4, label='pull')       # ramp of paper Eq 34
O.engines = [mpm,
             em.PlotRecorder(iterPeriod=100),                          # t, mpm_Ek, mpm_Ee, mpm_pull_Rx, ...
             em.VTKRecorder(fileName='out/bar-', iterPeriod=1000),     # .vtp series + .pvd for ParaView
             em.Progress(endIter=2000)]                               # progress and ETA
O.dt = 0.5 * em.criticalTimeStep()                                     # a dt above critical is refused
O.run(2000, True)
plot.plots = {'t': ('mpm_Ek', 'mpm_Ee')}
plot.plot(noShow=True).savefig('out/energy.png')
