"""The browser app (``naseview serve``): inspect a reconstruction and simulate changes live.

- :mod:`naseview.editing.state` — editor state and controller, no viser (undo / redo,
  symmetric mode, one solve worker, session files);
- :mod:`naseview.editing.solver` — the solver: landmark drags -> stage 3 deformation;
- :mod:`naseview.app.scene` — the shared 3D scene;
- :mod:`naseview.app.panels` — the control panel;
- :mod:`naseview.app.export` — downloadable files;
- :mod:`naseview.app.serve` — :func:`serve_command` and :class:`NaseviewApp`.
"""
