"""The live editor without a browser: drag landmarks, re-run stage 3's ARAP (paper §3.4).

- :mod:`~naseview.editing.baseline`: what is edited (:class:`Baseline`, from a pipeline
  result, a face model or a reconstruction folder), what a solver returns, what the page
  shows (:class:`Simulation`);
- :mod:`~naseview.editing.controller`: :class:`EditController`, drags, symmetric mode,
  undo / redo and the solve worker;
- :mod:`~naseview.editing.session`: ``naseview.session/1`` session files;
- :mod:`~naseview.editing.solver`: landmark drags -> the stage 3 deformation.
"""
