"""Periodic output engines: VTK files for ParaView, yade.plot data, progress with ETA."""
import os
import sys
import time

import numpy as np
from yade import O, PyRunner

from . import parallel
from .engines import ENGINE, _register, _releaseLabel, findEngine
from .params import Param, apply, declare


# The periods of a recorder; one of them must be > 0 (checked by _requirePeriod).
_ITER = Param("iterPeriod", 0, "iterations", "record every iterPeriod iterations (0: not by iterations)",
              bounds="[0, inf)")
_VIRT = Param("virtPeriod", 0.0, "s", "record every virtPeriod of simulated time (0: not by time)",
              bounds="[0, inf)")


def _requirePeriod(engine, owner):
    if not (engine.iterPeriod or engine.virtPeriod):
        raise ValueError(f"EigenMPM: give iterPeriod or virtPeriod (> 0) ({owner})")


@declare
class VTKRecorder(PyRunner):
    """Writes the material points of an MpmEngine as VTK XML poly data (``.vtp``, one file per
    record) plus a ParaView collection ``<fileName>.pvd`` with the time of each file. Point data
    (names, units and meanings in doc/output.md): velocity, displacement (from the reference
    configuration, where each point was added), stress and strain (3x3), psiPlus, H (history),
    damage (0 intact, 1 eroded), material. Periodic like YADE's VTKRecorder (iterPeriod or
    virtPeriod, one of them > 0); :meth:`finalRecord` adds the state at the end of a run when the
    last step was not recorded. When the solver stops on an error, the state at that moment is
    written as ``<fileName>failure.vtp``.

    Under mpiexec (doc/parallel.md) every rank writes its points as ``<fileName><iter>-r<rank>.vtp``
    and rank 0 a parallel file ``<fileName><iter>.pvtp`` naming the pieces, which the collection
    lists: ParaView opens the whole scene.

    Example::

        O.engines = [mpm, em.VTKRecorder(fileName='out/vtk/plate-', iterPeriod=500)]
    """

    _release = _releaseLabel  # (O.reset(): the label is free again)

    params = (
        Param("label", "mpmVtk", "", "YADE label of the engine"),
        ENGINE,
        Param("fileName", "mpm-", "", "path prefix of the files; directories are created",
              accepts="non-empty string", check=lambda f: f != ""),
        _ITER,
        _VIRT,
        Param("float32", False, "", "write positions and real-valued point data in single precision "
                                    "(about 7 significant digits, half the size of the files)"),
    )

    def __init__(self, **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "VTKRecorder")
        _requirePeriod(self, "VTKRecorder")
        self.initRun = True
        self.command = _register(self)
        self.files = []
        self._attached = None
        self._recordedSteps = None  # solver.steps of the last state written, to skip a duplicate

    def _mpm(self):
        mpm = findEngine(self.engine)
        if self._attached is not mpm:
            mpm.recorders.append(self)
            self._attached = mpm
        return mpm

    def _action(self):
        self.write(self._mpm())

    def onFailure(self, mpm, err):
        self.write(mpm, suffix="failure", index=False)

    def finalRecord(self):
        """Writes the current state as the last record of the series unless it is already
        written (the last step was recorded, or the solver failed and ``<fileName>failure.vtp``
        holds it). Returns the path written, or None."""
        mpm = self._mpm()
        if self._recordedSteps == mpm.solver.steps:
            return None
        return self.write(mpm)

    def pointData(self, mpm):
        """The point data written for `mpm`: name -> array (n or n x k), see doc/output.md."""
        s = mpm.solver
        x = s.positions()
        n = len(x)
        x0 = mpm.referenceOfPoints()
        if len(x0) != n:
            raise RuntimeError(f"EigenMPM: {n} points in the solver, {len(x0)} added through "
                               "MpmEngine.addPoints or fill; add points only through these")
        return {"velocity": s.velocities(), "displacement": x - x0,
                "stress": s.stress().reshape(n, 9), "strain": s.strain().reshape(n, 9),
                "psiPlus": s.psiPlus(), "H": s.history(),
                # the solver's c is 1 intact, 0 eroded (g(c) = c, paper Eq 21); output follows the
                # usual damage convention
                "damage": 1.0 - s.damage(), "material": s.material().astype(np.int32)}

    def write(self, mpm, suffix=None, index=True):
        """Writes the state of `mpm` as ``<fileName><iteration or suffix>.vtp``; with `index`,
        adds it to the collection. Returns the path."""
        from vtkmodules.util.numpy_support import numpy_to_vtk
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData
        from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

        s = mpm.solver
        real = np.float32 if self.float32 else np.float64
        x = s.positions()
        n = len(x)
        poly = vtkPolyData()
        pts = vtkPoints()
        pts.SetData(numpy_to_vtk(np.ascontiguousarray(x, dtype=real), deep=True))
        poly.SetPoints(pts)
        verts = vtkCellArray()
        conn = np.arange(n, dtype=np.int64)
        offsets = np.arange(n + 1, dtype=np.int64)
        verts.SetData(numpy_to_vtk(offsets, deep=True), numpy_to_vtk(conn, deep=True))
        poly.SetVerts(verts)
        for name, arr in self.pointData(mpm).items():
            arr = np.ascontiguousarray(arr, dtype=real if arr.dtype.kind == "f" else arr.dtype)
            a = numpy_to_vtk(arr, deep=True)
            a.SetName(name)
            poly.GetPointData().AddArray(a)
        tag = suffix if suffix else f"{O.iter:08d}"
        path = f"{self.fileName}{tag}.vtp" if s.ranks == 1 else f"{self.fileName}{tag}-r{s.rank}.vtp"
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        w = vtkXMLPolyDataWriter()
        partial = path + ".part"  # renamed when complete: an interrupted write leaves no broken file
        w.SetFileName(partial)
        w.SetInputData(poly)
        w.SetDataModeToAppended()
        w.SetCompressorTypeToZLib()
        if not w.Write():
            raise RuntimeError(f"EigenMPM: could not write {path}")
        os.replace(partial, path)
        self._recordedSteps = s.steps
        if s.ranks > 1:
            path = self._writeParallel(s, tag, poly)
            if not parallel.isRoot():
                return path
        if index:
            self.files.append((s.time, path))
            self._writeCollection()
        return path

    def _writeParallel(self, s, tag, poly):
        """Rank 0 writes ``<fileName><tag>.pvtp``, the parallel file of every rank's piece, once
        all are written. Returns its path."""
        import xml.etree.ElementTree as ET
        from mpi4py import MPI
        from vtkmodules.util.numpy_support import vtk_to_numpy
        MPI.COMM_WORLD.Barrier()
        pvtp = f"{self.fileName}{tag}.pvtp"
        if not parallel.isRoot():
            return pvtp

        def array(parent, vtkArray, name=None):
            a = vtk_to_numpy(vtkArray)
            kind = {"f": "Float", "i": "Int", "u": "UInt"}[a.dtype.kind]
            e = ET.SubElement(parent, "PDataArray", type=f"{kind}{8 * a.dtype.itemsize}",
                              NumberOfComponents=str(vtkArray.GetNumberOfComponents()))
            if name:
                e.set("Name", name)

        root = ET.Element("VTKFile", type="PPolyData", version="0.1", byte_order="LittleEndian")
        grid = ET.SubElement(root, "PPolyData", GhostLevel="0")
        data = ET.SubElement(grid, "PPointData")
        pd = poly.GetPointData()
        for k in range(pd.GetNumberOfArrays()):
            array(data, pd.GetArray(k), pd.GetArrayName(k))
        array(ET.SubElement(grid, "PPoints"), poly.GetPoints().GetData())
        for r in range(s.ranks):
            ET.SubElement(grid, "Piece", Source=os.path.basename(f"{self.fileName}{tag}-r{r}.vtp"))
        ET.indent(root)
        partial = pvtp + ".part"
        ET.ElementTree(root).write(partial, encoding="utf-8", xml_declaration=True)
        os.replace(partial, pvtp)
        return pvtp

    def _writeCollection(self):
        import xml.etree.ElementTree as ET
        pvd = f"{self.fileName}.pvd" if not self.fileName.endswith(("/", "-", "_")) else f"{self.fileName}series.pvd"
        base = os.path.dirname(os.path.abspath(pvd))
        root = ET.Element("VTKFile", type="Collection", version="0.1")
        collection = ET.SubElement(root, "Collection")
        for t, p in self.files:
            ET.SubElement(collection, "DataSet", timestep=f"{t:.12g}",
                          file=os.path.relpath(os.path.abspath(p), base))
        ET.indent(root)
        partial = pvd + ".part"
        ET.ElementTree(root).write(partial, encoding="utf-8", xml_declaration=True)
        os.replace(partial, pvd)
        self.collection = pvd


def _plot():
    """yade.plot, imported at the first record (not with the package: it loads matplotlib's
    settings); afterwards without the import statement, whose `from` form runs importlib's Python
    at every call (a record follows a step, when that code runs cold)."""
    global _plotModule
    if _plotModule is None:
        from yade import plot
        _plotModule = plot
    return _plotModule


_plotModule = None


@declare
class PlotRecorder(PyRunner):
    """Adds the MpmEngine's diagnostics to ``yade.plot`` every period: ``t`` (s), ``iter``, and
    ``<label>_Ek``, ``<label>_Ee`` (J) and ``<label>_<bc>_Rx`` ... (N) from MpmEngine.plotData.
    The period is iterPeriod or virtPeriod (one of them > 0).

    Example::

        from yade import plot
        O.engines = [mpm, em.PlotRecorder(iterPeriod=100)]
        O.run(10000, True)
        plot.saveDataTxt('out/energies.txt')
    """

    _release = _releaseLabel  # (O.reset(): the label is free again)

    params = (
        Param("label", "mpmPlot", "", "YADE label of the engine"),
        ENGINE,
        _ITER,
        _VIRT,
    )

    def __init__(self, **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "PlotRecorder")
        _requirePeriod(self, "PlotRecorder")
        self.initRun = True
        self.command = _register(self)

    def _action(self):
        mpm = findEngine(self.engine)
        # After the solver in O.engines the state is at solver.time (O.time advances later).
        _plot().addData(t=mpm.solver.time, iter=O.iter, **mpm.plotData())


@declare
class Progress(PyRunner):
    """Prints progress of a long run: iteration, simulated time, percentage, elapsed wall time and
    ETA, every realPeriod seconds of wall time. Give the end as endIter or endTime.

    Example::

        O.engines = [mpm, em.Progress(endIter=20000, realPeriod=30)]
        O.run(20000, True)
    """

    _release = _releaseLabel  # (O.reset(): the label is free again)

    params = (
        Param("label", "mpmProgress", "", "YADE label of the engine"),
        Param("endIter", None, "", "last iteration of the run", kind="int", bounds="[1, inf)"),
        Param("endTime", None, "s", "simulated time at the end of the run", kind="float", bounds="(0, inf)"),
        Param("realPeriod", 10.0, "s", "wall-clock seconds between reports", bounds="(0, inf)"),
        Param("stream", None, "", "where the reports go; default sys.stdout", kind="object",
              accepts="a file-like object (with write)", check=lambda f: hasattr(f, "write")),
    )

    def __init__(self, **kw):
        PyRunner.__init__(self)
        apply(self, self.params, kw, "Progress")
        if self.endIter is None and self.endTime is None:
            raise ValueError("EigenMPM: Progress needs endIter or endTime")
        self.initRun = True
        self.command = _register(self)
        self._start = None

    def fraction(self):
        if self.endIter:
            return min(O.iter / float(self.endIter), 1.0)
        return min(O.time / float(self.endTime), 1.0)

    def _action(self):
        now = time.time()
        if self._start is None:
            self._start = (now, self.fraction())
            return
        f = self.fraction()
        elapsed = now - self._start[0]
        done = f - self._start[1]
        eta = elapsed * (1.0 - f) / done if done > 0 else float("nan")
        if not parallel.isRoot():  # (under mpiexec one line for all ranks)
            return
        print(f"[EigenMPM] iter {O.iter}, t = {O.time:.6g} s, {100 * f:5.1f} %, "
              f"elapsed {elapsed:.0f} s, ETA {eta:.0f} s", file=self.stream or sys.stdout, flush=True)
