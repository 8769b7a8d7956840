"""What a failing slope did, frame by frame: the front of its deposit, its run-out beyond the
toe, and the scarp that a retrogressive failure steps back in.

A slope in 2D faces +x, its ground from y = 0; ``toe`` is the x of its toe, ``height`` its
height H.  At each frame:

- the **front**: the last grid column (width h) whose soil stands 2 % of H deep or more,
  and the run-out = front - toe;
- the **scarp**: the least initial x of the soil that has moved more than 2 % of H: the rear
  edge of the moving mass.  A retrogressive failure breaks off block after block, each
  behind the last, so the scarp steps back; each step back of more than a cell (steps in
  consecutive frames merged into one) is a **retrogression**, the first slide included.

A heuristic of the deposit's shape and the displacement field, not of the plastic strain:
it reads what an engineer reads from a run's frames.
"""
from dataclasses import dataclass

import numpy as np

from ..model.geometry import deposit_front

__all__ = ["Landslide"]

#: the share of H that counts as soil standing (the front) and as moved (the scarp)
SHARE = 0.02


@dataclass
class Landslide:
    """See the module: ``toe`` (m), ``height`` H (m)."""

    toe: float
    height: float

    def __post_init__(self):
        for name in ("toe", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not np.isfinite(value) or (name == "height"
                                                                     and value <= 0):
                raise ValueError(f"landslide: {name} must be a finite number"
                                 + (" > 0" if name == "height" else "") + f" (m), got {value!r}")

    def observe(self, x0, x, h) -> dict:
        """The frame's front and scarp from the initial positions ``x0`` and the positions
        ``x`` (n, 2) on a grid of spacing ``h``."""
        front = deposit_front(x, h, SHARE * self.height)
        moved = np.linalg.norm(x - x0, axis=1) > SHARE * self.height
        scarp = float(x0[moved, 0].min()) if np.any(moved) else float("nan")
        return {"front": front, "scarp": scarp}

    def summary(self, series, h) -> dict:
        """The run-out at the end, the scarp's retreat and the retrogressions counted from
        the frames' ``series`` (``front``, ``scarp``)."""
        front = np.asarray(series["front"], dtype=float)
        scarp = np.asarray(series["scarp"], dtype=float)
        moving = np.flatnonzero(np.isfinite(scarp))
        retrogressions, retreat = 0, 0.0
        if len(moving):
            s = np.minimum.accumulate(scarp[moving[0]:])  # the rearmost edge so far
            # the frames where the scarp appeared or stepped back by more than a cell; a
            # run of such frames is one slide growing
            changed = np.concatenate([[0], np.flatnonzero(np.diff(s) < -h) + 1])
            retrogressions = 1 + int(np.sum(np.diff(changed) > 1))
            retreat = float(s[0] - s[-1])
        return {"runout": float(front[-1] - self.toe) if len(front) else 0.0,
                "runout_over_H": float((front[-1] - self.toe) / self.height) if len(front)
                else 0.0,
                "scarp_retreat": retreat, "retrogressions": retrogressions}
