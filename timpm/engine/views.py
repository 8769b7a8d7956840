"""The state a phase, a law or a unit reads and writes, by name: the particle fields
(``particles.x``, ``particles.sigma``, ...) and the grid fields as the kernels name them
(``grid.node_mass``, ``grid.node_momentum``, ...; ``grid.band``, the 1D consistent mass).

A scheme's phase receives these and the run-time values (``values.dt()``) as arguments;
a material's law receives the particle fields with the little else it needs
(:class:`MaterialState`).  The views hold the program's own fields, so a phase compiles to
the same kernel as one reading them from the program."""

__all__ = ["FieldView", "MaterialState"]


class FieldView:
    """Fields by attribute (``view.x`` is the field named "x"); ``names`` lists them,
    ``fields`` maps them; ``storage`` names the fields behind them (the grid's storage
    names, ``engine/grid.py``'s ``NODE_NAMES``; the names themselves elsewhere)."""

    def __init__(self, what: str, fields: dict, storage=None):
        self._what = what
        self.names = tuple(fields)
        self.fields = dict(fields)
        self.storage = frozenset(fields if storage is None else storage)
        for name, fld in fields.items():
            setattr(self, name, fld)

    def __getattr__(self, name):  # a name not set: the feature set has no such field
        what, names = self.__dict__.get("_what"), self.__dict__.get("names", ())
        if name.startswith("__") or what is None:
            raise AttributeError(name)
        raise AttributeError(f"this program has no {what} field {name!r} (its {what} "
                             f"fields: {', '.join(names)})")

    def __repr__(self):
        return f"<{self._what} fields {', '.join(self.names)}>"


class MaterialState(FieldView):
    """What a material's law reads and writes of a particle (:mod:`timpm.materials.base`):
    the particle fields (``s.F[p]``, ``s.vol[p]``, ``s.plastic[p]``, ...), the dimension
    ``dim``, whether the volumes change (``update_volume``) and ``accumulate(ref, value)``,
    ``ref += value`` as the driver needs it.  The laws receive this, not the program."""

    def __init__(self, fields: dict, dim: int, update_volume: bool, accumulate):
        super().__init__("particle", fields)
        self.dim, self.update_volume, self.accumulate = dim, update_volume, accumulate
