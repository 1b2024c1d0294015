"""The browser app (``naseview serve``, viser): inspect a reconstruction and simulate changes
live. Only the command line imports this package; the state behind it lives in
:mod:`naseview.editing` (the live editor) and :mod:`naseview.intake` (a new patient).

- :mod:`naseview.app.serve` — :func:`serve_command` and :class:`NaseviewApp` (the
  patient's case, editor and jobs, shared by every tab);
- :mod:`naseview.app.screen` — one browser tab (its panels, scene, patient mode, camera),
  built in the tab's client scope (:mod:`naseview.app.scope`);
- :mod:`naseview.app.scene` — a tab's 3D scene;
- :mod:`naseview.app.panels` — a tab's control panel;
- :mod:`naseview.app.export` — downloadable files;
- :mod:`naseview.app.annotate_page` — the "new patient" page (photos, guided clicks), on
  :mod:`naseview.app.photo_plane`, :mod:`naseview.app.photo_camera` and
  :mod:`naseview.app.landmark_diagrams`;
- :mod:`naseview.app.patient_mode` — the presentation view and the consultation report;
- :mod:`naseview.app.host` — what those pages need from their tab;
- :mod:`naseview.app.headless_tab` — a tab without a browser (tests, benchmarks);
- :mod:`naseview.app.gui_value` — setting a GUI input's value, type-checked.
"""
