"""Landmark conventions of a face model checked on real faces (issue 23, deliverable 4).

For each real face of ``../shared/data/scan-cases`` (james-a: menpo3d's james scan,
BSD-3; lps-a: Lee Perry-Smith's head scan, Infinite-Realities, CC BY 3.0), the face model
is fitted **densely** to the true surface (similarity + identity coefficients, ICP on the
model vertices within 50 mm of prn, closest points on the truth mesh, the model's
Gaussian prior), starting from its fit to the true landmarks. Then, for each SPEC §1
landmark, the table prints where the model's landmark vertex lands against the landmark
as annotated on that face (distance and SPEC-frame offset, mm), and the vertex of the
fitted model nearest the annotated landmark over both faces (the vertex a convention
that matched the annotations would use).

A model vertex that misses the annotation on *both* faces by far more than the dense
fit's own error, in the same direction, is a convention that disagrees with SPEC §1.
docs/landmark-conventions.md holds the result and what was done with it.

    python benchmarks/bench_conventions.py [--model ict] [--cases james-a,lps-a]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import igl
import numpy as np
from _shared import use_shared_ict

from naseview.facemodel import FaceModel, load_face_model
from naseview.geometry.alignment import umeyama
from naseview.landmarks import LANDMARK_IDS
from naseview.meshio import read_mesh
from naseview.stage3_mesh import RefineParams
from naseview.stage3_mesh.fit import fit_face_model

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "scan-cases"

REACH_MM = 50.0
"""Model vertices within this of prn (and no more than 45 mm behind it) are fitted."""

MATCH_MM = (5.0, 3.0)
"""Closest-point matches farther than this are left out (first 4 rounds, then)."""


def _face(model: FaceModel, w: np.ndarray, s: float, R: np.ndarray, t: np.ndarray
          ) -> np.ndarray:
    """(V, 3) the model's face for coefficients w in the SPEC frame."""
    return np.asarray(s * (model.mean + np.tensordot(w, model.basis[:len(w)], 1)) @ R.T + t)


def dense_fit(model: FaceModel, V: np.ndarray, F: np.ndarray,
              landmarks: dict[str, np.ndarray], rounds: int = 12,
              sigma_mm: float = 0.5) -> tuple[np.ndarray, float]:
    """The model fitted to the surface (V, F): ((n, 3) fitted face, mean distance of the
    model's nose vertices to the surface, mm)."""
    fit = fit_face_model(model, landmarks, RefineParams(use_sublandmarks=False))
    w, s, R, t = fit.coefficients.copy(), fit.scale, fit.R, fit.t
    K = len(w)
    B = model.basis[:K]
    for it in range(rounds):
        X = _face(model, w, s, R, t)
        sel = np.flatnonzero((np.linalg.norm(X - landmarks["prn"], axis=1) < REACH_MM)
                             & (X[:, 2] > landmarks["prn"][2] - 45))
        d2, _, C = igl.point_mesh_squared_distance(np.ascontiguousarray(X[sel]), V, F)
        ok = np.sqrt(d2) < MATCH_MM[0 if it < 4 else 1]
        ids, Y = sel[ok], np.asarray(C)[ok]
        Xm = model.mean[ids] + np.tensordot(w, B[:, ids], 1)
        s, R, t = umeyama(Xm, Y, True)
        A = B[:, ids].reshape(K, -1).T * s                       # (3m, K), SPEC units
        r = ((Y - t) @ R - s * model.mean[ids]).ravel()          # target in the model frame
        lam = sigma_mm ** 2
        w = np.linalg.solve(A.T @ A + lam * np.eye(K), A.T @ r)
    X = _face(model, w, s, R, t)
    nose = np.asarray(model.nose_vertices)
    dn = np.sqrt(igl.point_mesh_squared_distance(np.ascontiguousarray(X[nose]), V, F)[0])
    return X, float(dn.mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", default="ict")
    ap.add_argument("--cases", default="james-a,lps-a")
    args = ap.parse_args()
    use_shared_ict()
    model = load_face_model(args.model)
    cases = args.cases.split(",")
    fits, truths = {}, {}
    for c in cases:
        d = SHARED / c
        tl = {k: np.asarray(v, float)
              for k, v in json.loads((d / "truth.json").read_text())["landmarks"].items()}
        V, F = read_mesh(d / "truth_face.ply")
        X, err = dense_fit(model, np.ascontiguousarray(V, float),
                           np.ascontiguousarray(F, np.int64), tl)
        fits[c], truths[c] = X, tl
        print(f"{c}: dense fit of '{model.name}', its nose vertices {err:.2f} mm from the "
              "true surface")
    skin = np.unique(np.asarray(model.faces))
    head = "landmark  vertex" + "".join(f"  {c + ' miss (dx, dy, dz)':>30s}" for c in cases)
    print("\n" + head + "   nearest over all  rms miss -> rms")
    print("-" * (len(head) + 36))
    for k in LANDMARK_IDS:
        v = model.landmark_vertices[k]
        row = f"{k:9s} {v:6d}"
        miss = []
        for c in cases:
            o = fits[c][v] - truths[c][k]
            miss.append(float(np.linalg.norm(o)))
            row += f"  {miss[-1]:5.1f} ({o[0]:+5.1f}, {o[1]:+5.1f}, {o[2]:+5.1f})".rjust(30)
        cost = sum(np.linalg.norm(fits[c][skin] - truths[c][k], axis=1) ** 2 for c in cases)
        j = int(skin[int(np.argmin(cost))])
        row += f"   {j:6d}          {np.sqrt(np.mean(np.square(miss))):4.1f} -> " \
               f"{np.sqrt(cost.min() / len(cases)):4.1f}"
        print(row)
    print("miss: the model's landmark vertex on the dense fit minus the annotated landmark "
          "(SPEC frame, mm: +x left, +y up, +z anterior)")


if __name__ == "__main__":
    main()
