"""Surgical manoeuvres as smooth displacement fields on the reconstruction.

Surgeons think in manoeuvres: each here is a documented, C1-smooth displacement field on
the rest shape (the reconstruction) with a millimetre or degree amount, zero outside the
nose and its fade bands; fields add (``D = sum_m D_m(amount_m)``), so a plan is
commutative and undoable.

- :mod:`.info`: :data:`MANOEUVRES` (:class:`ManoeuvreInfo`: title, unit, range, words),
  :func:`check_amounts`, :func:`describe_plan`;
- :mod:`.frame`: the nasal frame (n -> prn, anterior, lateral; nasal length and width)
  and the smooth weights;
- :mod:`.dorsum`: hump reduction, radix augmentation;
- :mod:`.tip`: tip projection, rotation, narrowing;
- :mod:`.alar_base`: alar base narrowing; :mod:`.columella`: columella setback;
- :mod:`.plan`: :class:`ManoeuvrePlan` (precompute once, apply many);
- :mod:`.folds`: :func:`folded_triangles`.

Example
-------
    plan = ManoeuvrePlan(b.V, b.F, b.nose_ids, b.landmarks, b.curves)
    V = b.V + plan.displacement({"hump_reduction": 2.0, "tip_rotation": 5.0})
    folded_triangles(b.V, V, b.F)          # -> empty
"""

from naseview.editing.manoeuvres.folds import folded_triangles
from naseview.editing.manoeuvres.info import (
    MANOEUVRES,
    ManoeuvreInfo,
    check_amounts,
    describe_plan,
)
from naseview.editing.manoeuvres.plan import ManoeuvrePlan

__all__ = ["MANOEUVRES", "ManoeuvreInfo", "ManoeuvrePlan", "check_amounts",
           "describe_plan", "folded_triangles"]
