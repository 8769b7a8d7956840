"""Particle fields of a run, written frame by frame: ParaView files or NumPy archives.

``FieldWriter(directory, format="vtk")`` writes, at every ``write(solver)``, one file of
the particles' data: ``particles_00000.vtu`` (VTK unstructured points, written by
pyevtk) and the time series ``particles.pvd`` that ParaView opens (rewritten after every
frame, so an interrupted run leaves a readable series); ``format="npz"`` writes
``particles_00000.npz`` (NumPy) instead.  Every file is written under a temporary name
and renamed (:func:`timpm.platform.files.replacing`): a frame on disk is whole.

The fields (:func:`particle_fields`): position (as the VTK points), displacement,
velocity, volume, mass, the Cauchy stress (``stress_xx``, ``stress_xy``, ... in the VTK
files, one array per component; the (n, dim, dim) tensor in the archives), pressure and
von Mises stress, the material and body of each particle, and the materials' own state
where the scene keeps it (``plastic_strain``, ``J``).

``grid=True`` adds the grid at every frame (:func:`grid_fields`): the nodal mass and
velocity projected from the particles then (P2G alone, between two steps: the run is not
changed), as ``grid_00000.vti`` (VTK image data) with the series ``grid.pvd``, or as
``grid_mass`` and ``grid_velocity`` arrays (with ``grid_origin`` and ``grid_spacing``) in
the frame's archive.
"""
import os
from pathlib import Path

import numpy as np

from ..platform.files import check_output, check_output_dir, replacing

__all__ = ["FORMATS", "FieldWriter", "particle_fields", "grid_fields",
           "check_output_directory", "check_output_file"]

FORMATS = ("vtk", "npz")
AXES = "xyz"


def check_output_directory(directory, what="output directory") -> Path:
    """``directory`` as a Path, created if missing (its parent must exist), refused when
    it is a file or no file can be written in it: before any work."""
    return Path(check_output_dir(directory, what))


def check_output_file(path, what="output file", formats=None) -> Path:
    """``path`` refused before any work when it cannot be written (see
    :func:`timpm.platform.files.check_output`)."""
    return Path(check_output(path, what, formats))


def particle_fields(solver) -> dict:
    """The particle data of ``solver`` now, by name: (n,) scalars, (n, dim) vectors and
    the (n, dim, dim) stress."""
    n, dim = solver.n_particles, solver.dim
    model = solver.model
    stress = np.asarray(solver.stresses(), dtype=np.float64).reshape(n, dim, dim)
    pressure = -np.trace(stress, axis1=1, axis2=2) / dim
    deviator = stress + pressure[:, None, None] * np.eye(dim)
    out = {
        "position": solver.positions().reshape(n, dim),
        "displacement": solver.displacements().reshape(n, dim),
        "velocity": solver.velocities().reshape(n, dim),
        "volume": np.asarray(solver.volumes(), dtype=np.float64).reshape(n),
        "mass": np.asarray(model.mass_per_particle, dtype=np.float64).reshape(n),
        "stress": stress,
        "pressure": pressure,
        "von_mises": np.sqrt(1.5 * np.einsum("pij,pij->p", deviator, deviator)),
        "material": np.asarray(model.material_index, dtype=np.int32).reshape(n),
        "body": np.asarray(model.body_index, dtype=np.int32).reshape(n),
    }
    kept = solver.memory()["particle_fields"]
    for field, name in (("plastic", "plastic_strain"), ("J", "J")):
        if field in kept:
            out[name] = np.asarray(solver.read(field), dtype=np.float64).reshape(n)
    return out


def grid_fields(solver) -> dict:
    """The grid now: ``mass`` (nodes) and ``velocity`` (nodes x dim; zero where a node has
    no mass) projected from the particles, the ``origin`` and the ``spacing``."""
    mass, momentum = solver.project()
    dim = solver.dim
    mass = np.asarray(mass, dtype=np.float64).reshape(tuple(solver.grid_nodes))
    momentum = np.asarray(momentum, dtype=np.float64).reshape(mass.shape + (dim,))
    velocity = np.zeros_like(momentum)
    filled = mass > 0
    velocity[filled] = momentum[filled] / mass[filled][:, None]
    return {"mass": mass, "velocity": velocity,
            "origin": np.asarray(solver.origin, dtype=np.float64).reshape(dim),
            "spacing": np.full(dim, float(solver.h))}


class FieldWriter:
    """Frames of particle fields in ``directory`` (created if missing): ParaView
    (``format="vtk"``) or NumPy (``"npz"``), with the grid's where ``grid``; see the
    module."""

    def __init__(self, directory, format="vtk", prefix="particles", grid=False):
        if format not in FORMATS:
            raise ValueError(f"unknown field format {format!r}: choose one of "
                             f"{', '.join(FORMATS)}")
        if not isinstance(prefix, str) or not prefix or os.sep in prefix:
            raise ValueError(f"prefix must be a plain file name, got {prefix!r}")
        self.directory = check_output_directory(directory)
        self.format, self.prefix, self.grid = format, prefix, bool(grid)
        self._remove_stale_frames()
        self.frames = []  # (file name, simulated time)
        self.grid_frames = []
        if format == "vtk":
            import importlib

            importlib.import_module("pyevtk.hl")  # a missing package fails here, not later

    def _remove_stale_frames(self):
        """Frames of an earlier series in the directory (this writer's names: PREFIX_NNNNN
        and grid_NNNNN, their .pvd) go first: a shorter new series must not end in the old
        one's frames."""
        import re

        pattern = re.compile(rf"({re.escape(self.prefix)}|grid)_\d{{5}}\.(npz|vtu|vti)$")
        for entry in self.directory.iterdir():
            if entry.is_file() and (pattern.match(entry.name) or entry.name in (
                    f"{self.prefix}.pvd", "grid.pvd")):
                entry.unlink()

    @property
    def series(self) -> Path:
        """The ParaView time series (``.pvd``; vtk format)."""
        return self.directory / f"{self.prefix}.pvd"

    @property
    def grid_series(self) -> Path:
        """The grid's ParaView time series (``grid.pvd``; vtk format, ``grid=True``)."""
        return self.directory / "grid.pvd"

    def write(self, solver) -> Path:
        """One frame: the fields of ``solver`` at its current time."""
        fields = particle_fields(solver)
        grid = grid_fields(solver) if self.grid else None
        index = len(self.frames)
        name = f"{self.prefix}_{index:05d}"
        # pyevtk appends the suffix to the name it is given: the temporary names keep it
        if self.format == "npz":
            path = self.directory / f"{name}.npz"
            extra = {f"grid_{k}": v for k, v in grid.items()} if grid else {}
            with replacing(path, ".npz") as tmp:
                np.savez(tmp, t=solver.t, step=solver.step, **fields, **extra)
        else:
            path = self.directory / f"{name}.vtu"
            with replacing(path, ".vtu") as tmp:
                _write_vtu(tmp[:-len(".vtu")], fields)
        self.frames.append((path.name, float(solver.t)))
        if self.format == "vtk":
            _write_series(self.directory, self.frames, self.series)
            if grid is not None:
                image = self.directory / f"grid_{index:05d}.vti"
                with replacing(image, ".vti") as tmp:
                    _write_vti(tmp[:-len(".vti")], grid)
                self.grid_frames.append((image.name, float(solver.t)))
                _write_series(self.directory, self.grid_frames, self.grid_series)
        return path


def _write_series(directory, frames, series):
    """The ``.pvd`` collection of ``frames`` ((file name, time), ...) at ``series``."""
    from pyevtk.vtk import VtkGroup

    with replacing(series, ".pvd") as tmp:
        group = VtkGroup(tmp[:-len(".pvd")])
        for name, t in frames:
            group.addFile(str(directory / name), sim_time=t)
        group.save()


def _write_vti(base, grid):
    """The grid as VTK image data (pyevtk): node values padded to 3D."""
    from pyevtk.hl import imageToVTK

    dim = grid["mass"].ndim
    shape = grid["mass"].shape + (1,) * (3 - dim)

    def volume(a):
        return np.asfortranarray(np.asarray(a, dtype=np.float64).reshape(shape))

    velocity = tuple(volume(grid["velocity"][..., k]) if k < dim else volume(
        np.zeros(grid["mass"].shape)) for k in range(3))
    pad = lambda a, fill: tuple(float(v) for v in a) + (fill,) * (3 - dim)  # noqa: E731
    imageToVTK(base, origin=pad(grid["origin"], 0.0), spacing=pad(grid["spacing"], 1.0),
               pointData={"mass": volume(grid["mass"]), "velocity": velocity})


def _write_vtu(base, fields):
    """Unstructured points (pyevtk): the positions padded to 3D, vectors as 3-component
    arrays, the stress one array per component."""
    from pyevtk.hl import pointsToVTK

    n, dim = fields["position"].shape
    column = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731

    def vector(a):
        return tuple(column(a[:, k]) if k < dim else np.zeros(n) for k in range(3))

    data = {}
    for name, value in fields.items():
        if name == "position":
            continue
        if name == "stress":
            for i in range(dim):
                for j in range(i, dim):
                    data[f"stress_{AXES[i]}{AXES[j]}"] = column(value[:, i, j])
        elif value.ndim == 2:
            data[name] = vector(value)
        else:
            data[name] = column(value)
    x, y, z = vector(fields["position"])
    pointsToVTK(base, x, y, z, data=data)
