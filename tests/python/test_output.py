"""VTK output (VTKRecorder): displacement from the reference configuration, the damage
convention, the final record, a collection file that stays valid XML whatever the file names,
single-precision output. The fields are listed in doc/output.md."""
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from yade import O, pack

import eigenmpm as em

H = 0.01


def read(path):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    r = vtkXMLPolyDataReader()
    r.SetFileName(str(path))
    r.Update()
    out = r.GetOutput()
    pd = out.GetPointData()
    fields = {pd.GetArrayName(i): vtk_to_numpy(pd.GetArray(i)) for i in range(pd.GetNumberOfArrays())}
    return vtk_to_numpy(out.GetPoints().GetData()), fields


def moving_block(velocity=(1.0, 0, 0)):
    mpm = em.MpmEngine(h=H, domain=((-0.05, -0.05, 0), (0.5, 0.1, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.1, 0.05, 0)), em.ElasticMaterial(E=30e9, nu=0.2, rho=2400),
             velocity=velocity)
    O.dt = 0.5 * mpm.criticalTimeStep()
    return mpm


def test_displacement_is_measured_from_where_the_points_were_added(tmp_path):
    # The recorder joins after two thirds of the motion; its displacement is still the whole
    # motion since the points were added, not the last third.
    mpm = moving_block()
    x0 = mpm.solver.positions().copy()
    O.engines = [mpm]
    O.run(20, True)
    rec = em.VTKRecorder(fileName=str(tmp_path / "d-"), iterPeriod=5)
    O.engines = [mpm, rec]
    O.run(10, True)
    rec.finalRecord()
    x, fields = read(rec.files[-1][1])
    assert np.array_equal(x, mpm.solver.positions())
    assert np.array_equal(fields["displacement"], x - x0)
    assert fields["displacement"][:, 0].mean() == pytest.approx(1.0 * mpm.solver.time, rel=1e-6)


def test_points_added_after_steps_have_their_own_reference(tmp_path):
    mpm = moving_block()
    O.engines = [mpm]
    O.run(5, True)
    late = mpm.addPoints([(0.3, 0.02, 0)], em.ElasticMaterial(E=30e9, nu=0.2, rho=2400), 1e-6)
    rec = em.VTKRecorder(fileName=str(tmp_path / "late-"), iterPeriod=1)
    O.engines = [mpm, rec]
    O.run(1, True)
    _, fields = read(rec.files[-1][1])
    assert np.allclose(fields["displacement"][late[0]], mpm.solver.positions()[late[0]] - (0.3, 0.02, 0),
                       rtol=0, atol=1e-15)


def test_damage_is_zero_intact_and_one_eroded(tmp_path):
    # Every node moves with v = (10 x, 0): uniform tension erodes all points at once (test_erosion),
    # after about 50 steps.
    mpm = em.MpmEngine(h=H, domain=((-0.05, -0.05, 0), (0.25, 0.1, 0)))
    mpm.fill(pack.inAlignedBox((0, 0, 0), (0.2, 0.05, 0)), em.ElasticMaterial(E=1e9, nu=0.25, rho=1000))
    for xi in np.unique(mpm.solver.nodePositions()[:, 0]):
        mpm.velocityBC(region=pack.inAlignedBox((xi - 1e-6, -1, -1), (xi + 1e-6, 1, 1)), components="xy",
                       velocity=(10 * xi, 0, 0))
    er = em.EigenErosion(engine=mpm, Gc=50.0, alpha=1.5, kappa=1.1 * H, iterPeriod=1)
    rec = em.VTKRecorder(fileName=str(tmp_path / "e-"), iterPeriod=99)
    O.engines = [mpm, er, rec]
    O.dt = 0.5 * mpm.criticalTimeStep()
    O.run(100, True)
    assert er.erodedCount() == mpm.solver.numPoints
    first, last = (read(p)[1]["damage"] for _, p in rec.files)
    assert np.all(first == 0.0) and np.all(last == 1.0)


def test_final_record_is_written_once(tmp_path):
    mpm = moving_block()
    rec = em.VTKRecorder(fileName=str(tmp_path / "f-"), iterPeriod=4)
    O.engines = [mpm, rec]
    O.run(10, True)  # records at iterations 0, 4, 8; the state after step 10 is not recorded
    assert len(rec.files) == 3
    path = rec.finalRecord()
    assert path and len(rec.files) == 4 and rec.files[-1][1] == path
    assert rec.files[-1][0] == pytest.approx(mpm.solver.time, rel=1e-12)
    x, _ = read(path)
    assert np.array_equal(x, mpm.solver.positions())
    assert rec.finalRecord() is None and len(rec.files) == 4
    O.run(3, True)  # iteration 12 is recorded and is the last step: nothing to add
    assert len(rec.files) == 5 and rec.finalRecord() is None
    assert ET.parse(rec.collection).getroot().find("Collection").__len__() == 5


def test_collection_is_valid_xml_for_any_file_name(tmp_path):
    mpm = moving_block()
    prefix = tmp_path / 'a&b<c"d' / 'x&<">-'
    rec = em.VTKRecorder(fileName=str(prefix), iterPeriod=2)
    O.engines = [mpm, rec]
    O.run(5, True)
    root = ET.parse(rec.collection).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    sets = root.find("Collection").findall("DataSet")
    assert [os.path.join(os.path.dirname(rec.collection), d.get("file")) for d in sets] == [p for _, p in rec.files]
    assert [float(d.get("timestep")) for d in sets] == pytest.approx([t for t, _ in rec.files], rel=1e-11)
    assert all(os.path.exists(p) for _, p in rec.files)
    assert not list(tmp_path.rglob("*.part"))


def test_float32_output_halves_the_precision_not_the_fields(tmp_path):
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    mpm = moving_block()
    full = em.VTKRecorder(fileName=str(tmp_path / "d64-"), iterPeriod=5, label="v64")
    half = em.VTKRecorder(fileName=str(tmp_path / "d32-"), iterPeriod=5, float32=True, label="v32")
    O.engines = [mpm, full, half]
    O.run(6, True)
    x64, f64 = read(full.files[-1][1])
    x32, f32 = read(half.files[-1][1])
    assert x64.dtype == np.float64 and x32.dtype == np.float32
    assert set(f32) == set(f64)
    for name, a in f64.items():
        b = f32[name]
        if name == "material":
            assert a.dtype == b.dtype == np.int32 and np.array_equal(a, b)
            continue
        assert a.dtype == np.float64 and b.dtype == np.float32, name
        scale = max(np.abs(a).max(), 1e-300)
        assert np.abs(b - a).max() <= 1e-6 * scale, name
    r = vtkXMLPolyDataReader()
    r.SetFileName(half.files[-1][1])
    r.Update()
    assert r.GetOutput().GetNumberOfPoints() == len(x64)
