"""Field output: ParaView time series read back by an independent reader (meshio), NumPy
frames, and output paths refused before the run."""
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import assert_same_run

from timpm.cli.main import main
from timpm.output.fields import FieldWriter
from timpm.scenarios import run_demo
from timpm.studies.study import run_problem


def test_disks_demo_written_for_paraview_is_read_back(tmp_path):
    meshio = pytest.importorskip("meshio")
    frames = 3
    result = run_demo("disks", frames=frames, cells=16, fields=FieldWriter(tmp_path / "vtk"))
    solver = result.solver
    n = result.particles
    series = ET.parse(tmp_path / "vtk" / "particles.pvd").getroot()
    entries = series.find("Collection").findall("DataSet")
    assert len(entries) == frames + 1
    times = [float(e.get("timestep")) for e in entries]
    assert times[0] == 0.0 and times[-1] == pytest.approx(solver.t)
    last = meshio.read(tmp_path / "vtk" / entries[-1].get("file"))
    data = last.point_data
    # every particle, at its position, with its velocity and every stress component
    assert last.points.shape == (n, 3)
    np.testing.assert_allclose(last.points[:, :2], solver.positions(), rtol=1e-15)
    np.testing.assert_allclose(data["velocity"][:, :2], solver.velocities(), rtol=1e-15)
    stress = solver.stresses()
    assert np.abs(stress).max() > 1.0  # the disks collided: stressed
    for name, (i, j) in (("stress_xx", (0, 0)), ("stress_xy", (0, 1)), ("stress_yy", (1, 1))):
        np.testing.assert_allclose(data[name].ravel(), stress[:, i, j], rtol=1e-15)
    np.testing.assert_allclose(data["volume"].ravel(), solver.volumes(), rtol=1e-15)
    assert set(np.unique(data["body"])) == {0, 1}  # two disks
    result.solver.release()


def test_run_writes_numpy_frames_spread_over_the_run(tmp_path):
    assert main(["run", "vibrating-string", "--npz", str(tmp_path / "npz"), "--frames", "4",
                 "--quiet"]) == 0
    files = sorted((tmp_path / "npz").glob("particles_*.npz"))
    assert len(files) == 5
    frames = [np.load(f) for f in files]
    np.testing.assert_allclose([f["t"] for f in frames], [0.0, 0.025, 0.05, 0.075, 0.1])
    assert [int(f["step"]) for f in frames] == [0, 250, 500, 750, 1000]
    # the displacement is the exact solution's to the run's accuracy (e_RMS 5.4e-5)
    r = run_problem("vibrating-string")
    np.testing.assert_allclose(frames[-1]["displacement"][:, 0], r.displacement, rtol=1e-12)
    assert frames[-1]["stress"].shape == (64, 1, 1)
    assert not list((tmp_path / "npz").glob(".*tmp*"))  # no half-written file left


def _read_vti(path):
    """Point arrays of a VTK image (raw appended data, UInt64 headers): an independent
    reading of the format (https://docs.vtk.org/en/latest/design_documents/VTKFileFormats.html),
    x fastest."""
    raw = path.read_bytes()
    head, data = raw.split(b'<AppendedData encoding="raw">', 1)
    data = data[data.index(b"_") + 1:]
    root = ET.fromstring(head.decode() + "</VTKFile>")
    image = root.find("ImageData")
    extent = [int(v) for v in image.get("WholeExtent").split()]
    shape = tuple(extent[2 * k + 1] - extent[2 * k] + 1 for k in range(3))
    out = {"origin": [float(v) for v in image.get("Origin").split()],
           "spacing": [float(v) for v in image.get("Spacing").split()]}
    for array in image.iter("DataArray"):
        offset, comps = int(array.get("offset")), int(array.get("NumberOfComponents"))
        size = int(np.frombuffer(data, np.uint64, 1, offset)[0])
        values = np.frombuffer(data, np.float64, size // 8, offset + 8)
        out[array.get("Name")] = values.reshape(shape[::-1] + (comps,)).transpose(2, 1, 0, 3)
    return out


def test_grid_mass_and_velocity_written_with_the_particles(tmp_path):
    """--grid: each frame's nodal mass sums to the particles' mass and its momentum to
    theirs (the basis is a partition of unity), in the .vti images and the .npz frames;
    writing them does not change the run."""
    from timpm.output.fields import grid_fields

    plain = run_demo("disks", frames=2, cells=16)
    result = run_demo("disks", frames=2, cells=16,
                      fields=FieldWriter(tmp_path / "vtk", grid=True))
    solver = result.solver
    assert_same_run(solver.positions(), plain.solver.positions())
    entries = ET.parse(tmp_path / "vtk" / "grid.pvd").getroot().find("Collection")
    files = [e.get("file") for e in entries.findall("DataSet")]
    assert len(files) == 3
    image = _read_vti(tmp_path / "vtk" / files[-1])
    mass, velocity = image["mass"][:, :, 0, 0], image["velocity"][:, :, 0, :2]
    particles_mass = solver.read("m")
    momentum = (particles_mass[:, None] * solver.velocities()).sum(axis=0)
    assert mass.sum() == pytest.approx(particles_mass.sum(), rel=1e-12)
    # the disks' momenta cancel: compare to the round-off of the momentum magnitudes
    scale = np.abs(particles_mass[:, None] * solver.velocities()).sum()
    assert scale > 1.0
    np.testing.assert_allclose((mass[..., None] * velocity).sum(axis=(0, 1)), momentum,
                               rtol=0, atol=1e-13 * scale)
    grid = grid_fields(solver)
    assert_same_run(mass, grid["mass"])  # the projection again: the same sums
    assert image["origin"][:2] == list(grid["origin"])
    assert image["spacing"][:2] == list(grid["spacing"])
    for r in (plain, result):
        r.solver.release()
    assert main(["run", "vibrating-string", "--npz", str(tmp_path / "npz"), "--grid",
                 "--frames", "1", "--quiet"]) == 0
    last = np.load(sorted((tmp_path / "npz").glob("particles_*.npz"))[-1])
    assert last["grid_mass"].sum() == pytest.approx(last["mass"].sum(), rel=1e-12)


def test_run_records_carry_the_time_series_as_json_and_csv(tmp_path):
    import json

    assert main(["run", "vibrating-string", "--json", str(tmp_path / "r.json"),
                 "--csv", str(tmp_path / "r.csv"), "--quiet"]) == 0
    series = json.load(open(tmp_path / "r.json"))["runs"][0]["series"]
    table = np.genfromtxt(tmp_path / "r.csv", delimiter=",", names=True)
    assert set(table.dtype.names) == set(series)
    for name in ("t", "u", "u_exact", "energy_kinetic", "energy_total"):
        np.testing.assert_array_equal(table[name], series[name])
    # the monitored particle follows its exact series; the energy is conserved
    assert np.max(np.abs(table["u"] - table["u_exact"])) < 1e-4
    assert np.ptp(table["energy_total"]) < 1e-3 * table["energy_total"][0]
    assert table["t"][-1] == pytest.approx(0.1)


@pytest.mark.parametrize("argv, message", [
    (["--vtk", "{tmp}/a_file"], "is a file, not a directory"),
    (["--vtk", "{tmp}/missing/deeper"], "its parent directory"),
    (["--vtk", "{tmp}/v", "--npz", "{tmp}/n"], "choose one field format"),
    (["--grid"], "give --vtk DIR or --npz DIR too"),
    (["--json", "{tmp}"], "is a directory"),
    (["--csv", "{tmp}/missing/r.csv"], "does not exist"),
    (["--plot", "{tmp}/missing/r.png"], "does not exist"),
])
def test_bad_output_directories_are_refused_before_the_run(tmp_path, capsys, argv, message):
    (tmp_path / "a_file").write_text("")
    argv = [a.format(tmp=tmp_path) for a in argv]
    assert main(["run", "vibrating-string", *argv]) == 2
    err = capsys.readouterr()
    assert message in err.err
    assert "elements" not in err.out  # no table: nothing ran


def test_bad_writer_arguments_are_refused(tmp_path):
    with pytest.raises(ValueError, match="unknown field format 'vtp'"):
        FieldWriter(tmp_path, format="vtp")
    with pytest.raises(ValueError, match="frames must be a positive integer, got 0"):
        run_problem("vibrating-string", fields=FieldWriter(tmp_path), frames=0)
