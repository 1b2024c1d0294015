"""The guided click order of a new patient: which photo first, which landmark next.

Which landmarks each photo shows is :data:`naseview.landmarks.VIEW_LANDMARKS` (SPEC §1-2);
this module only orders them, along the paper's boundary curves (§3.3, Fig. 14), so the
hand moves little. Import fails if the two tables ever disagree.

Click order and why
-------------------
Photos: ``front``, ``bottom``, ``left``, ``right`` (:data:`VIEW_ORDER`). The bottom photo
comes second because stage 1 fixes its 3D frame with a left/right pair and ``g`` seen in
two photos each: after front + bottom the pairs are there, and the sixth click in the
left photo (``g n k r prn c``) already brings ``g`` into a second photo, so the remaining
8 left clicks and most right clicks are shown with a reprojected hint.

Within a photo (subject's right = image left in the front and bottom photos):

- ``front``: down the mid-curve ``g n k r prn c sn``; round the lobule from the subject's
  right to left along the nostril / C-curve (``alpp_r md_r alp_r`` then ``alp_l md_l
  alpp_l``); then one loop over the sides: up the left ala-curve (``ac_l al_l int_l``) and
  side-curve (``mf_l``), across the nasal root (``mf_r``) and down the right side-curve and
  ala-curve (``int_r al_r ac_r``).
- ``left`` / ``right``: the profile (mid-curve) ``g n k r prn c sn``, then that side's
  lobule points next to ``sn`` (``alpp md alp``), then the ala-curve backwards and the
  side-curve up (``ac al int mf``).
- ``bottom``: the bottom curve from end to end (``ac_r al_r alp_r add_r prn add_l alp_l
  al_l ac_l``, with the ``add`` helpers between ``al'`` and ``prn`` where SPEC §5 puts
  them), then back through the inside of the base: ``alpp_l md_l c md_r alpp_r sn``.

Every landmark can be skipped where it is not visible (a profile hides the far side).

Example
-------
>>> CLICK_ORDER["left"][:7]
('g', 'n', 'k', 'r', 'prn', 'c', 'sn')
>>> describe("al_l", "front")
"al (al_l): alare: most lateral point of the ala (subject's left); image right side"
"""

from __future__ import annotations

from naseview.landmarks import ALL_IDS, ALL_VIEWS, LANDMARKS, OBLIQUE_VIEWS, VIEW_LANDMARKS, VIEWS

VIEW_ORDER: tuple[str, ...] = ("front", "bottom", "left", "right")
"""Guided order of the four required photos (see the module docstring for why bottom is
second)."""

PHOTO_ORDER: tuple[str, ...] = VIEW_ORDER + OBLIQUE_VIEWS
"""Guided order of every photo: the four, then the optional obliques (issue 24)."""

CLICK_ORDER: dict[str, tuple[str, ...]] = {
    "front": ("g", "n", "k", "r", "prn", "c", "sn",
              "alpp_r", "md_r", "alp_r", "alp_l", "md_l", "alpp_l",
              "ac_l", "al_l", "int_l", "mf_l", "mf_r", "int_r", "al_r", "ac_r"),
    "bottom": ("ac_r", "al_r", "alp_r", "add_r", "prn", "add_l", "alp_l", "al_l", "ac_l",
               "alpp_l", "md_l", "c", "md_r", "alpp_r", "sn"),
    "left": ("g", "n", "k", "r", "prn", "c", "sn",
             "alpp_l", "md_l", "alp_l", "ac_l", "al_l", "int_l", "mf_l"),
    "right": ("g", "n", "k", "r", "prn", "c", "sn",
              "alpp_r", "md_r", "alp_r", "ac_r", "al_r", "int_r", "mf_r"),
    # a 3/4 photo shows the nasal root from the side, which a profile often hides: glabella
    # and both medial canthi first, then the profile and its own side's ala
    "oblique_left": ("g", "mf_l", "mf_r", "n", "k", "r", "prn", "c", "sn",
                     "alpp_l", "md_l", "alp_l", "ac_l", "al_l", "int_l", "md_r"),
    "oblique_right": ("g", "mf_r", "mf_l", "n", "k", "r", "prn", "c", "sn",
                      "alpp_r", "md_r", "alp_r", "ac_r", "al_r", "int_r", "md_l"),
}
"""Per photo, the landmarks of :data:`naseview.landmarks.VIEW_LANDMARKS` in click order
(module docstring)."""

VIEW_TITLES: dict[str, str] = {
    "front": "Front photo", "bottom": "Bottom (basal) photo",
    "left": "Left profile (camera on the subject's left)",
    "right": "Right profile (camera on the subject's right)",
    "oblique_left": "Left oblique (¾, camera about 45° towards the subject's left; optional)",
    "oblique_right": "Right oblique (¾, camera about 45° towards the subject's right; "
                     "optional)",
}
"""Heading of each photo in the page."""


def _check_tables() -> None:
    """Every photo asks for exactly its :data:`VIEW_LANDMARKS`, each once, and every
    landmark and helper is asked for somewhere (raises at import otherwise)."""
    if set(VIEW_ORDER) != set(VIEWS) or set(CLICK_ORDER) != set(ALL_VIEWS):
        raise AssertionError(f"VIEW_ORDER must list {VIEWS}, CLICK_ORDER {ALL_VIEWS}")
    for v, ids in CLICK_ORDER.items():
        if len(set(ids)) != len(ids) or set(ids) != set(VIEW_LANDMARKS[v]):
            raise AssertionError(f"CLICK_ORDER[{v!r}] must order VIEW_LANDMARKS[{v!r}], "
                                 "each landmark once")
    asked = {i for ids in CLICK_ORDER.values() for i in ids}
    if asked != set(ALL_IDS):
        raise AssertionError(f"landmarks never asked for: {sorted(set(ALL_IDS) - asked)}")


_check_tables()


def describe(landmark_id: str, view: str | None = None) -> str:
    """One line for the page: paper name, SPEC id, soft-tissue definition and, for the
    front and bottom photos, on which side of the image a left/right landmark lies."""
    lm = LANDMARKS[landmark_id]
    return f"{lm.paper} ({lm.id}): {definition(landmark_id, view)}"


def definition(landmark_id: str, view: str | None = None) -> str:
    """The soft-tissue definition of a landmark and, for the front and bottom photos, on
    which side of the image a left/right landmark lies (:func:`describe` without the
    paper's abbreviation and the id, for a page that names landmarks its own way).

    >>> definition("alpp_r", "bottom")[-15:]
    'image left side'
    """
    lm = LANDMARKS[landmark_id]
    text = lm.description
    if view in ("front", "bottom") and lm.side in ("l", "r"):
        text += "; image " + ("right" if lm.side == "l" else "left") + " side"
    if lm.helper:
        text += "; 2D helper, halfway along the outline"
    return text
