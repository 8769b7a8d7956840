"""Element tests of a soil law: one material point under a homogeneous deformation.

The geotechnical laboratory's tests, run on the compiled law itself (its ``update`` as
the engine calls it, on a particle state of one point):

- ``biaxial-mc``: drained plane-strain biaxial compression (2D): the sample first under
  the confining pressure p all round (sigma_zz included), then shortened along y at a
  constant rate while sigma_xx = -p is held (the lateral strain solved for in every
  increment) and the out-of-plane strain stays zero;
- ``triaxial-mc``: drained triaxial compression (3D), sigma_xx = sigma_zz = -p held.

Mohr-Coulomb fails both at the deviator q = sigma_1 - sigma_3 = (2 c cos(phi) + 2 p
sin(phi)) / (1 - sin(phi)) (compression positive; :meth:`MohrCoulomb.peak_deviator`),
which the record holds as ``exact_peak_deviator`` beside the ``peak_deviator`` found.
The record also holds the stress path (mean stress, deviator) and the volumetric strain
against the axial strain: dilatancy where the dilation angle is not zero.
"""
import math
import time

import numpy as np
import taichi as ti

__all__ = ["ELEMENT_TESTS", "ElementTest", "run_element_test", "plot_element_test", "summary"]

#: test name -> dimension
ELEMENT_TESTS = {"biaxial-mc": 2, "triaxial-mc": 3}

#: the default sample: a dense sand with some cohesion (kPa and m)
DEFAULTS = dict(E=1e5, nu=0.3, density=2000.0, friction_angle=30.0, cohesion=10.0,
                dilation_angle=0.0, confinement=100.0, axial_strain=0.03, increments=600)


class ElementTest:
    """A material point of one law in ``dim`` dimensions, driven by velocity gradients: the
    particle state the law's ``update`` reads (the mass, the volume and the state the law
    declares it keeps, ``Material.particle_fields``: ``F``, ``plastic``, a hardening
    variable ...) beside the total deformation gradient and the stress.  ``trial(grad)``
    applies one increment to the committed state and returns sigma_xx; ``commit()`` keeps
    it and returns the state."""

    def __init__(self, material, dim):
        from ..engine.params import ParamBlock
        from ..engine.scatter import accumulate_in
        from ..engine.views import MaterialState

        if dim not in material.dims:
            raise ValueError(f"{material.name} is written for {material.dims}-D, not {dim}-D")
        self.material, self.dim = material, dim
        d, real = dim, float
        fb = ti.FieldsBuilder()
        block = ParamBlock({"m0": {name: "real" for name in material.CONSTANTS}}, real, fb)
        self._block = block
        unit = self.unit = type(material).unit(material.flags(), block.groups["m0"])
        # entry 0: the committed state; entry 1: an increment tried from it
        self.declared = type(material).particle_fields(dim)
        law = {name: _field(fld, d, real) for name, fld in self.declared.items()}
        self.fields = {"F_total": ti.Matrix.field(d, d, real),
                       "sigma": ti.Matrix.field(d, d, real), "m": ti.field(real),
                       "vol": ti.field(real), **law}
        fb.dense(ti.i, 2).place(*self.fields.values())
        # the committed state packed for one read: each field's entries in turn, then V / V0
        self.columns, size = {}, 0
        for name, fld in self.fields.items():
            shape = ((fld.n, fld.m) if isinstance(fld, ti.MatrixField) and fld.ndim == 2 else
                     (fld.n,) if isinstance(fld, ti.MatrixField) else ())
            self.columns[name] = (size, shape)
            size += int(np.prod(shape))
        self.pack = ti.field(real)
        fb.dense(ti.i, size + 1).place(self.pack)
        self._tree = fb.finalize()
        self.set_material(material)
        state = self.state = MaterialState(self.fields, dim, True, accumulate_in("serial"))
        F_total, sigma, vol, m = (self.fields[k] for k in ("F_total", "sigma", "vol", "m"))
        names, columns, pack = tuple(law), self.columns, self.pack

        @ti.kernel
        def trial(grad: ti.types.matrix(d, d, real)) -> real:
            # the increment from the committed state; returns sigma_xx
            sxx = 0.0
            for _ in range(1):
                for name in ti.static(names):
                    ti.static(law[name])[1] = ti.static(law[name])[0]
                F_total[1] = (ti.Matrix.identity(real, d) + grad) @ F_total[0]
                vol[1] = m[1] / unit.c.density() * F_total[1].determinant()
                sigma[1] = unit.update(state, 1, grad, sigma[0])
                sxx = sigma[1][0, 0]
            return sxx

        @ti.kernel
        def commit():
            # the tried increment kept, and packed for one read
            for _ in range(1):
                for name in ti.static(tuple(self.fields)):
                    fld = ti.static(self.fields[name])
                    fld[0] = fld[1]
                    col, shape = ti.static(columns[name])
                    if ti.static(len(shape) == 0):
                        pack[col] = fld[0]
                    elif ti.static(len(shape) == 2):  # a matrix, row by row
                        for k in ti.static(range(shape[0] * shape[1])):
                            pack[col + k] = fld[0][k // shape[1], k % shape[1]]
                    else:
                        for k in ti.static(range(shape[0])):
                            pack[col + k] = fld[0][k]
                pack[size] = vol[0] * unit.c.density() / m[0]

        self._trial, self._commit = trial, commit

    #: the points built in this process, by (law, its compile-time flags, dimension): a
    #: law's constants are run-time values, so one compiled point serves every sample
    _BUILT = {}

    @classmethod
    def of(cls, material, dim):
        """A point of ``material`` in ``dim`` dimensions, compiled once per law and flags
        (Taichi started with timpm's defaults if nothing started it)."""
        from ..platform.runtime import ensure_init

        ensure_init()
        key = (type(material), material.flags(), dim)
        point = cls._BUILT.get(key)
        if point is None or point.generation != _generation():
            point = cls._BUILT[key] = cls(material, dim)
        else:
            point.set_material(material)
        return point

    def set_material(self, material):
        """This point's law takes ``material``'s constants (same law and flags)."""
        self.material = material
        self._block.set("m0", material.constants(1.0, 1.0))  # (one point: h = 1)
        self._block.upload()
        self.generation = _generation()  # the Taichi start its fields belong to

    def start(self, confinement):
        """The sample under the pressure ``confinement`` all round, the reference
        configuration (F_total = I, V = V0): the state the law takes from that stress
        (``Material.initial_state``: a Hencky law's elastic strain -p / (3 lambda + 2 mu)
        along every axis, out of plane too), its other fields at their initial values.
        ``confinement = 0``: every field at its initial value (any law: unstressed)."""
        mat, d = self.material, self.dim
        stress = -confinement * np.eye(3)[None]
        start = mat.initial_state(stress, d) if confinement != 0.0 else {}
        values = {"F_total": np.eye(d), "sigma": -confinement * np.eye(d),
                  "m": mat.density, "vol": 1.0}
        for name, fld in self.declared.items():
            if name in start:
                values[name] = np.asarray(start[name])[0]
            elif fld.initial == "identity":
                values[name] = np.eye(d)
            else:
                values[name] = np.full(fld.entries(d), float(fld.initial))
        for name, fld in self.fields.items():
            value = np.asarray(values[name], dtype=float)
            fld.from_numpy(np.broadcast_to(value, (2,) + value.shape).copy())

    def trial(self, grad) -> float:
        """sigma_xx after the increment ``grad`` from the committed state."""
        return float(self._trial(np.asarray(grad, dtype=float)))

    def commit(self) -> dict:
        """Keep the tried increment; returns the committed state (one read): every field by
        name, scalars as floats."""
        self._commit()
        a = self.pack.to_numpy()
        out = {}
        for name, (col, shape) in self.columns.items():
            entry = a[col:col + int(np.prod(shape))]
            out[name] = float(entry[0]) if not shape else entry.reshape(shape)
        return out


def _soil_laws():
    """The laws an element test takes: the registry's soil laws (a friction angle and a
    cohesion, a closed-form peak deviator), in its order."""
    from ..materials import MATERIALS

    return tuple(name for name, cls in MATERIALS.items()
                 if {"friction_angle", "cohesion"} <= set(cls.PARAMS)
                 and hasattr(cls, "peak_deviator"))


#: the laws an element test takes
LAWS = _soil_laws()


def run_element_test(test="biaxial-mc", progress=None, law="mohr-coulomb", **params):
    """Run an element test (``ELEMENT_TESTS``) of a sample of ``law`` (``LAWS``), ``params``
    overriding ``DEFAULTS`` (and setting the law's own parameters, ``Material.PARAMS``);
    returns the record (numbers, the stress path and the series of the scalar state the
    law keeps: ``plastic``, a hardening variable).  ``progress(done, n)`` is called as the
    increments go (about a thousand times).  Under ``deferred_sigint`` a Ctrl-C, SIGTERM
    or SIGHUP stops the test after the increment it is in: the record then holds the
    increments done (``increments_done``) and says so (``interrupted``).  A sample with
    no strength (c = 0 and p = 0, or phi = 0) has a closed-form peak of 0 and no
    relative error (None): ``peak_absolute_error`` is its error."""
    import inspect

    from ..materials import MATERIALS
    from ..platform import interrupt

    if law not in LAWS:
        raise ValueError(f"unknown law {law!r}: an element test takes {', '.join(LAWS)}")

    if test not in ELEMENT_TESTS:
        raise ValueError(f"unknown element test {test!r}: choose one of "
                         f"{', '.join(ELEMENT_TESTS)}")
    cls = MATERIALS[law]
    known = list(DEFAULTS) + [k for k in cls.PARAMS if k not in DEFAULTS]
    unknown = set(params) - set(known)
    if unknown:
        raise ValueError(f"{test} has no parameter {', '.join(sorted(unknown))}; its "
                         f"parameters are {', '.join(known)}")
    p = {**DEFAULTS, **params}
    confinement, axial, n = float(p["confinement"]), float(p["axial_strain"]), p["increments"]
    if not (confinement >= 0.0 and math.isfinite(confinement)):
        raise ValueError(f"{test}: confinement must be a pressure >= 0, got {p['confinement']!r}")
    if not (0.0 < axial < 0.5):
        raise ValueError(f"{test}: axial_strain must lie in (0, 0.5), got {p['axial_strain']!r}")
    if isinstance(n, float) and n.is_integer():
        n = int(n)
    if isinstance(n, bool) or not isinstance(n, int) or not (10 <= n <= 1_000_000):
        raise ValueError(f"{test}: increments must be a whole number in [10, 1e6], got {n!r}")
    takes = inspect.signature(cls.__init__).parameters
    missing = [k for k, a in takes.items() if k != "self" and a.default is a.empty
               and k not in p]
    if missing:
        raise ValueError(f"{test}: the {law} law has no default for {', '.join(missing)}: "
                         f"give {missing[0]}=VALUE (on the command line --param "
                         f"{missing[0]}=VALUE)")
    material = cls(**{k: v for k, v in p.items() if k in takes})
    dim = ELEMENT_TESTS[test]
    t0 = time.perf_counter()
    point = ElementTest.of(material, dim)
    point.start(confinement)
    lateral = [0] if dim == 2 else [0, 2]  # the axes held at -confinement; y is axial
    stretch = math.exp(-axial / n) - 1.0  # the axial log strain in equal steps
    stiff = material.lam + 2.0 * material.mu
    a = -material.nu / (1.0 - material.nu) * stretch if dim == 2 else -material.nu * stretch
    eps_a, q, mean, vol, plastic = [0.0], [0.0], [confinement], [0.0], [0.0]
    # the plastic parts of the axial shortening and of ln J: the total less the change of
    # the elastic log strains (coaxial: F_e stays diagonal)
    first = point.commit()  # (the committed start, unchanged)
    e0 = _elastic_log_strains(point.dim, first)
    kept = [name for name, fld in point.declared.items() if fld.shape == "scalar"]
    state_series = {name: [first[name]] for name in kept}
    plastic_axial, plastic_volume = [0.0], [0.0]
    tol = 1e-10 * max(confinement, material.cohesion, 1.0)
    done, every = n, max(1, n // 1000)
    for k in range(n):
        if interrupt.requested():  # a signal under deferred_sigint: keep what was done
            done = k
            break

        def residual(x):  # sigma_xx + p after the increment with lateral stretch x
            return point.trial(_increment(dim, stretch, lateral, x)) + confinement

        # the lateral stretch that holds sigma_xx = -p (the residual rises with it,
        # piecewise smooth): bracketed from a step of the elastic stiffness, then the
        # Illinois false position
        a = _root(residual, a, stiff, tol, f"{test}: increment {k}")
        point.trial(_increment(dim, stretch, lateral, a))
        state = point.commit()
        sig = state["sigma"]
        J = float(np.linalg.det(state["F_total"]))
        eps_a.append(-math.log(state["F_total"][1, 1]))
        q.append(float(sig[0, 0] - sig[1, 1]))  # sigma_1 - sigma_3 (compression positive)
        e = _elastic_log_strains(dim, state)
        plastic_axial.append(eps_a[-1] + (e[1] - e0[1]))
        plastic_volume.append(math.log(J) - (e.sum() - e0.sum()))
        total = float(np.trace(sig))
        if dim == 2:  # and sigma_zz, from the elastic strains
            total += float((material.lam * e.sum() + 2.0 * material.mu * e[2]) / J)
        mean.append(-total / 3.0)
        vol.append(math.log(J))
        plastic.append(state.get("plastic", 0.0))
        for name in kept:
            state_series[name].append(state[name])
        if progress is not None and ((k + 1) % every == 0 or k + 1 == n):
            progress(k + 1, n)
    q_arr = np.array(q)
    peak = float(q_arr.max())
    exact = material.peak_deviator(confinement, dim)
    out = {
        "problem": test, "dim": dim, "material": law,
        "params": {k: (float(v) if k != "increments" else n) for k, v in p.items()},
        "increments_done": done,
        "peak_deviator": peak, "exact_peak_deviator": exact,
        "peak_relative_error": abs(peak - exact) / exact if exact > 0 else None,
        "peak_absolute_error": abs(peak - exact),
        "axial_strain_at_peak": float(eps_a[int(q_arr.argmax())]),
        "final_volumetric_strain": vol[-1], "final_plastic_strain": plastic[-1],
        "wall_seconds": time.perf_counter() - t0,
        "series": {"axial_strain": eps_a, "deviator": q, "mean_stress": mean,
                   "volumetric_strain": vol, "plastic_strain": plastic,
                   "plastic_axial_strain": plastic_axial,
                   "plastic_volumetric_strain": plastic_volume,
                   "state": state_series},
    }
    if done < n:
        out["interrupted"] = (f"{test} interrupted after {done} of {n} increments (axial "
                              f"strain {eps_a[-1]:.4g} of {axial:g})")
    return out


def summary(record) -> str:
    """The record's line on the command line: the peak against the closed form (the
    absolute error where the closed form is 0: a sample without strength)."""
    peak, exact = record["peak_deviator"], record["exact_peak_deviator"]
    err = record["peak_relative_error"]
    how = (f"relative error {err:.2e}" if err is not None else
           f"error {record['peak_absolute_error']:.3g} Pa: no strength, c = 0 with p = 0 or "
           "phi = 0")
    n = record["params"]["increments"]
    if record["increments_done"] < n:  # interrupted: the peak so far
        how = f"the peak so far, after {record['increments_done']} of {n} increments"
    return (f"{record['problem']}: peak deviator {peak:.6g}, closed form {exact:.6g} ({how}) "
            f"at axial strain {100 * record['axial_strain_at_peak']:.3g}%; volumetric strain "
            f"at the end {100 * record['final_volumetric_strain']:.3g}%")


def _root(fn, x0, slope, tol, where):
    """A root of the increasing function ``fn`` near ``x0``: a bracket grown from a Newton
    step of ``slope``, then the Illinois false position."""
    r0 = fn(x0)
    if abs(r0) <= tol:
        return x0
    x1 = x0 - r0 / slope
    r1 = fn(x1)
    for _ in range(80):  # grow the bracket
        if r0 * r1 <= 0.0:
            break
        x0, r0, x1 = x1, r1, x1 + 2.0 * (x1 - x0)
        r1 = fn(x1)
    else:
        raise RuntimeError(f"{where}: no lateral strain holds the confining pressure")
    side = 0
    for _ in range(200):
        x = x1 - r1 * (x1 - x0) / (r1 - r0)
        r = fn(x)
        if abs(r) <= tol:
            return x
        if r * r1 < 0.0:
            x0, r0 = x1, r1
            side = 0
        else:
            r0 = r0 / 2.0 if side == 1 else r0  # Illinois: halve the stale end
            side = 1
        x1, r1 = x, r
    raise RuntimeError(f"{where}: the lateral stress did not settle")


def _generation():
    from ..platform import runtime
    return runtime.generation()


def _increment(dim, axial, lateral, x):
    """The velocity gradient times dt of an increment: ``axial`` along y, ``x`` along the
    lateral axes."""
    grad = np.zeros((dim, dim))
    grad[1, 1] = axial
    for i in lateral:
        grad[i, i] = x
    return grad


def _elastic_log_strains(dim, state):
    """The elastic log strains along x, y, z of a committed state (coaxial loading: F_e
    diagonal; in 2D the out-of-plane one from ``ezz``, zero for a law that keeps none)."""
    F = state["F"]
    e = [math.log(F[k, k]) for k in range(dim)]
    if dim == 2:
        e.append(state.get("ezz", 0.0))
    return np.array(e)


def _field(fld, d, real):
    """The Taichi field of a declaration (``timpm.platform.declare.Field``)."""
    entries = fld.entries(d)
    dtype = ti.i32 if fld.dtype == "int" else real
    if not entries:
        return ti.field(dtype)
    if len(entries) == 1:
        return ti.Vector.field(entries[0], dtype)
    return ti.Matrix.field(entries[0], entries[1], dtype)


def plot_element_test(record, path):
    """The deviator and the volumetric strain against the axial strain, the closed-form
    peak drawn across."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = record["series"]
    ea = 100.0 * np.asarray(s["axial_strain"])
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(13, 4))
    ax1.plot(ea, s["deviator"], label=f"timpm ({record['material']}, Hencky)")
    ax1.axhline(record["exact_peak_deviator"], color="k", ls="--",
                label="closed form of the surface")
    ax1.set(xlabel="axial strain [%]", ylabel="deviator sigma_1 - sigma_3 [kPa]")
    ax1.legend(fontsize=8)
    ax2.plot(ea, 100.0 * np.asarray(s["volumetric_strain"]))
    ax2.set(xlabel="axial strain [%]", ylabel="volumetric strain ln J [%] (dilation > 0)")
    ax3.plot(s["mean_stress"], s["deviator"])
    ax3.set(xlabel="mean stress p' [kPa]", ylabel="deviator q [kPa]")
    prm = record["params"]
    fig.suptitle(f"{record['problem']}: phi = {prm['friction_angle']:g} deg, c = "
                 f"{prm['cohesion']:g}, psi = {prm['dilation_angle']:g} deg, confinement "
                 f"{prm['confinement']:g}; peak {record['peak_deviator']:.4g} against "
                 f"{record['exact_peak_deviator']:.4g}")
    fig.tight_layout()
    from ..platform.files import replacing
    with replacing(path, ".png") as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)
