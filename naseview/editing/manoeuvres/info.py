"""The manoeuvre catalogue: names, units, clinical ranges, words for surgeon and patient.

:data:`MANOEUVRES` lists every manoeuvre in display order; :func:`check_amounts` validates
a ``name -> amount`` mapping (mm or degrees) against it; :func:`describe_plan` turns the
non-zero amounts into patient sentences.

Example
-------
>>> check_amounts({"hump_reduction": 2, "tip_rotation": 0.0})
{'hump_reduction': 2.0}
>>> describe_plan({"tip_projection": 1.5})
['Bring the tip of the nose forward by 1.5 mm']
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass

from naseview.errors import NaseviewError


@dataclass(frozen=True)
class ManoeuvreInfo:
    """What one manoeuvre is and which amounts it allows.

    Attributes:
        name: key in an amounts mapping (``"hump_reduction"``).
        title: surgeon's name (``"Dorsal hump reduction"``).
        unit: ``"mm"`` or ``"deg"``.
        low, high: the clinical range the control allows (no fold-overs inside, tested).
        step: GUI step (0.1 mm / 0.5 deg).
        definition: one paragraph for the surgeon: what moves, which way, how it fades.
        plain: patient words, a format string with ``{amount}``.
        per_side: the amount is per side (each side moves by it; a width falls by
            twice it): the control says so (:attr:`control_label`).
    """

    name: str
    title: str
    unit: str
    low: float
    high: float
    step: float
    definition: str
    plain: str
    per_side: bool = False

    @property
    def unit_label(self) -> str:
        """The unit as a control shows it: ``"°"``, ``"mm"``, ``"mm per side"``."""
        u = "°" if self.unit == "deg" else self.unit
        return f"{u} per side" if self.per_side else u

    @property
    def control_label(self) -> str:
        """The control's label: ``"Alar base narrowing (mm per side)"``."""
        return f"{self.title} ({self.unit_label})"


_ALL = (
    ManoeuvreInfo(
        "hump_reduction", "Dorsal hump reduction", "mm", 0.0, 5.0, 0.1,
        "Lowers the dorsum between the radix (n) and the tip (prn) along the posterior "
        "normal of the n-prn line, in proportion to the profile's height above that line, "
        "so the dorsal hump depth falls by the amount; an amount past the measured hump is "
        "applied only up to it (+0.25 mm), where the dorsum is straight (more would crease "
        "it into a saddle), and the plan says so; a hump measured in the supratip (its "
        "top within 15 % of the nasal length above the tip) is the lobule's convexity: "
        "lowering it sharpens the tip, and the plan says that too; n and prn stay; fades "
        "to zero on the "
        "sidewalls about a fifth of the alar width either side of the midline.",
        "Lower the bump on the bridge of the nose by {amount} mm"),
    ManoeuvreInfo(
        "radix_augmentation", "Radix augmentation", "mm", -2.0, 4.0, 0.1,
        "Moves the radix (around n) out along the bisector of the nasofrontal angle "
        "(negative: deepens it); n moves by the amount; fades up to the glabella, along "
        "the upper dorsum and onto the medial canthal region.",
        "Build up the top of the nose between the eyes by {amount} mm"),
    ManoeuvreInfo(
        "tip_projection", "Tip projection", "mm", -4.0, 4.0, 0.1,
        "Moves the tip lobule (around prn) anteriorly (+z, away from the face; negative: "
        "deprojection); prn moves by the amount; fades over the supratip, the columella "
        "towards sn and the domes towards the alae.",
        "Bring the tip of the nose forward by {amount} mm"),
    ManoeuvreInfo(
        "tip_rotation", "Tip rotation", "deg", -10.0, 15.0, 0.5,
        "Rotates the tip lobule and columella about the transverse axis through the alar "
        "crease midpoint (mean of ac_l, ac_r); positive = cephalic (tip up); the measured "
        "tip rotation (columellar-facial angle) changes by the angle: the columella, held "
        "at the lip, tilts more or less than the lobule turns, so the lobule's turn is "
        "scaled on each face (prn turns by the angle divided by that face's gain, 0.7-2); "
        "fades over the supratip, the alae and into the upper lip.",
        "Turn the tip of the nose upwards by {amount} degrees"),
    ManoeuvreInfo(
        "tip_narrowing", "Tip narrowing", "mm", 0.0, 4.0, 0.1,
        "Moves the two halves of the tip lobule towards the midline, smoothly across it, "
        "so the tip width (the dome distance md_l-md_r) falls by the amount (half per "
        "side); fades towards the alae, the supratip and the columella base.",
        "Make the tip of the nose narrower by {amount} mm"),
    ManoeuvreInfo(
        "alar_base_narrowing", "Alar base narrowing", "mm", 0.0, 4.0, 0.1,
        "Moves each ala together with its alar crease (ac, al, the alar groove and the "
        "nostril sill) medially by the amount on each side, so the alar base width "
        "(ac_l-ac_r) and the nasal width (al_l-al_r) fall by twice the amount; fades into "
        "the cheek, the upper lip and the nasal sidewall over a band wide enough that "
        "nothing folds.",
        "Make the base of the nostrils narrower by {amount} mm on each side",
        per_side=True),
    ManoeuvreInfo(
        "columella_setback", "Columella setback", "mm", 0.0, 4.0, 0.1,
        "Moves the hanging columella (between c and sn) up into the nostrils, "
        "perpendicular to the c-sn line (cephalic and posterior), so the columellar show "
        "(read at mid-columella) falls by the amount; zero at the tip lobule (c) and at "
        "the lip (sn).",
        "Raise the strip of skin between the nostrils by {amount} mm"),
)

MANOEUVRES: dict[str, ManoeuvreInfo] = {m.name: m for m in _ALL}
"""Every manoeuvre by name, in display order."""


MEASURES: dict[str, tuple[str, float]] = {
    "hump_reduction": ("dorsal_hump_depth", -1.0),
    "radix_augmentation": ("radix_height", 1.0),
    "tip_projection": ("tip_projection", 1.0),
    "tip_rotation": ("tip_rotation", 1.0),
    "tip_narrowing": ("tip_width", -1.0),
    "alar_base_narrowing": ("alar_base", -2.0),
    "columella_setback": ("columellar_show", -1.0),
}
"""Manoeuvre -> (the measurement it names, its change per unit amount): a manoeuvre of
amount ``x`` changes that measurement by ``x`` times the factor (within 10 %,
``benchmarks/bench_plan.py``)."""


def expected_change(name: str, amount: float) -> float:
    """The change of :data:`MEASURES` ``[name]``'s measurement a manoeuvre of ``amount``
    is meant to make (mm, degrees)."""
    return MEASURES[name][1] * float(amount)


def _fmt(x: float) -> str:
    """``2.0`` -> ``"2"``, ``1.25`` -> ``"1.25"``."""
    return f"{x:g}"


def check_amounts(amounts: object, where: str = "manoeuvres") -> dict[str, float]:
    """Validate a ``name -> amount`` mapping against :data:`MANOEUVRES`.

    Args:
        amounts: a mapping of manoeuvre name -> number (mm or degrees).
        where: what to name in the error (file, key).
    Returns:
        name -> float amount, zeros dropped, in the mapping's order.
    Raises:
        NaseviewError: not a mapping, an unknown name, a non-number, a non-finite amount
            or one outside ``[low, high]`` (one line naming ``where``, the key, the range
            and the fix).
    """
    if not isinstance(amounts, Mapping):
        raise NaseviewError(f"{where}: expected an object of manoeuvre name -> amount, got "
                            f"{type(amounts).__name__}")
    out: dict[str, float] = {}
    for name, value in amounts.items():
        info = MANOEUVRES.get(name) if isinstance(name, str) else None
        if info is None:
            raise NaseviewError(f"{where}: unknown manoeuvre {name!r}; use one of "
                                f"{', '.join(MANOEUVRES)}")
        rng = f"{_fmt(info.low)}..{_fmt(info.high)} {info.unit}"
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise NaseviewError(f"{where}: key {name!r}: expected a number in {rng}, got "
                                f"{str(value)[:40]!r}")
        try:
            x = float(value)
        except OverflowError:
            x = math.inf
        if not math.isfinite(x):
            raise NaseviewError(f"{where}: key {name!r}: amount {x} is not finite; give a "
                                f"number in {rng}")
        if not info.low <= x <= info.high:
            raise NaseviewError(f"{where}: key {name!r}: {_fmt(x)} {info.unit} is outside "
                                f"the allowed range {rng}; choose an amount inside it")
        if x != 0.0:
            out[name] = x
    return out


def describe_plan(amounts: Mapping[str, float]) -> list[str]:
    """Patient sentences (:attr:`ManoeuvreInfo.plain`) of the non-zero manoeuvres, in
    :data:`MANOEUVRES` order; a negative amount is described by its size (``plain`` of a
    negative radix or tip amount reads "by -1 mm", so those say "deepen" / "set back")."""
    out = []
    for name, info in MANOEUVRES.items():
        x = float(amounts.get(name, 0.0))
        if x == 0.0 or not math.isfinite(x):
            continue
        if x < 0 and name in _NEGATIVE:
            out.append(_NEGATIVE[name].format(amount=_fmt(-x)))
        else:
            out.append(info.plain.format(amount=_fmt(x)))
    return out


_NEGATIVE: dict[str, str] = {
    "radix_augmentation": "Deepen the top of the nose between the eyes by {amount} mm",
    "tip_projection": "Set the tip of the nose back by {amount} mm",
    "tip_rotation": "Turn the tip of the nose downwards by {amount} degrees",
}
"""Patient words for the negative direction of the two-sided manoeuvres."""
