"""The patient's own face: texture maps baked from the photos, and the simulation shown on
the photos themselves.

- :mod:`naseview.texture.uv` — one-chart UV parametrisation of a face mesh (cached per
  topology);
- :mod:`naseview.texture.bake` — projective texturing from the four photos
  (:class:`FaceTexture`);
- :mod:`naseview.texture.composite` — the edited face rendered back into a photo ("after"
  photo), before/after blend and ghost;
- :mod:`naseview.texture.views` — textured renders of standard clinical views (PNG);
- :mod:`naseview.texture.mesh_files` — mesh files of the face with its texture (the app's
  downloads and ``naseview reconstruct --export glb``).
"""
