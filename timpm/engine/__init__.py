"""The engine: a scene's feature set (compile time) and layout (run time), the compiled step
program of a feature set, and the state of one scene.

- :mod:`.features`: ``plan(scene, options) -> (FeatureSet, Layout)``;
- :mod:`.schemes`: the transfer schemes, one file each, a step as a list of phases;
- :mod:`.program`: ``Program``, fields at a capacity and kernels; the scheme's phases and
  the operations they call come from one unit each: :mod:`.stencil`, :mod:`.scatter`,
  :mod:`.grid`, :mod:`.consistent_mass`, :mod:`.transfer`, :mod:`.rk4`, :mod:`.midpoint`,
  :mod:`.mls_projection`, :mod:`.recorder`, :mod:`.drivers`; run-time values in
  :mod:`.params`;
- :mod:`.program_cache`: one program per feature set per process (``program_for``), at a
  ``Capacity`` that grows;
- :mod:`.state`: ``State``, one scene's data in and out of its program.
"""
