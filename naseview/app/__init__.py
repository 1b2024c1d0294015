"""The browser app (``naseview serve``, viser): inspect a reconstruction and simulate changes
live. Only the command line imports this package; the state behind it lives in
:mod:`naseview.editing` (the live editor) and :mod:`naseview.intake` (a new patient).

- :mod:`naseview.app.serve` — :func:`serve_command` and :class:`NaseviewApp`;
- :mod:`naseview.app.scene` — the shared 3D scene;
- :mod:`naseview.app.panels` — the control panel;
- :mod:`naseview.app.export` — downloadable files;
- :mod:`naseview.app.annotate_page` — the "new patient" page (photos, guided clicks), on
  :mod:`naseview.app.photo_plane`, :mod:`naseview.app.photo_camera` and
  :mod:`naseview.app.landmark_diagrams`;
- :mod:`naseview.app.patient_mode` — the presentation view and the consultation report;
- :mod:`naseview.app.host` — what those pages need from the app;
- :mod:`naseview.app.gui_value` — setting a GUI input's value, type-checked.
"""
