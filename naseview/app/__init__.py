"""The browser app (``naseview serve``, viser): inspect a reconstruction and simulate changes
live. Only the command line imports this package; the state behind it lives in
:mod:`naseview.editing` (the live editor) and :mod:`naseview.intake` (a new patient).

- :mod:`naseview.app.serve` — the entry point: :func:`serve_command`, :func:`start_app`;
- :mod:`naseview.app.naseview_app` — :class:`NaseviewApp` (the patient's case, editor
  and jobs, shared by every tab), its jobs (:mod:`naseview.app.jobs`) and downloads
  (:mod:`naseview.app.downloads`);
- :mod:`naseview.app.screen` — one browser tab (its panels, scene, patient mode, camera),
  built in the tab's client scope (:mod:`naseview.app.scope`); it sees the app as
  :class:`~naseview.app.screen.ScreenHost`;
- :mod:`naseview.app.scene` — a tab's 3D scene (its geometry:
  :mod:`naseview.app.scene_geometry`);
- :mod:`naseview.app.panels` — a tab's control panel;
- :mod:`naseview.app.export` — downloadable landmarks and measurements (the meshes:
  :mod:`naseview.texture.mesh_files`);
- :mod:`naseview.app.annotate_page` — the "new patient" page (photos, guided clicks):
  its panel (:mod:`naseview.app.annotate_panel`), photo view
  (:mod:`naseview.app.annotate_photo`) and click flow (:mod:`naseview.app.annotate_clicks`),
  on :mod:`naseview.app.photo_plane`, :mod:`naseview.app.photo_camera` and
  :mod:`naseview.app.landmark_diagrams`;
- :mod:`naseview.app.patient_mode` — the presentation view and the consultation report;
- :mod:`naseview.app.patients_panel` — the patient's work and the patient list;
- :mod:`naseview.app.host` — what those pages need from their tab (one protocol each);
- :mod:`naseview.app.headless_tab` — a tab without a browser (tests, benchmarks);
- :mod:`naseview.app.gui_value` — setting a GUI input's value, type-checked.
"""
