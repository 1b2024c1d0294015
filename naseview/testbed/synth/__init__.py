"""Synthetic cases with exact ground truth: ``naseview synth`` (the test bed, SPEC §3, §7).

A synthetic case is what a surgeon would bring (four phone photos of a face against a
clinic backdrop, the 21 landmark clicks, a calliper distance; SPEC §3) plus the truth
(SPEC §7). Everything is rendered by :mod:`naseview.render` from a random identity of a
:class:`~naseview.facemodel.FaceModel`, so every number in the truth is exact. One module
per job, in the order a case is made:

- :mod:`~naseview.testbed.synth.rig`: the random face and the four phone cameras;
- :mod:`~naseview.testbed.synth.scene`: face, head proxy and eyes with their albedo
  (:mod:`~naseview.testbed.synth.features`, :mod:`~naseview.testbed.synth.skin`,
  :mod:`~naseview.testbed.synth.head`, :mod:`~naseview.testbed.synth.eyes`,
  :mod:`~naseview.testbed.synth.blend`);
- :mod:`~naseview.testbed.synth.photo`: backdrop, lights, shading, blur, sensor noise;
- :mod:`~naseview.testbed.synth.clicks`: which landmarks are clicked where;
- :mod:`~naseview.testbed.synth.truth`: true curves, 2D boundaries, helper points;
- :mod:`~naseview.testbed.synth.synthesize`: :func:`synthesize_case`, the files;
- :mod:`~naseview.testbed.synth.command`: :func:`synth_command`, ``naseview synth``.

When the ICT model is used, credit "ICT Face Model (USC Institute for Creative
Technologies, MIT)" travels in ``truth.json`` (``synth.credit``).

Example
-------
>>> from naseview.facemodel import load_face_model
>>> synthesize_case("/tmp/case", load_face_model("generic"), seed=7)   # doctest: +SKIP
PosixPath('/tmp/case/case.json')
"""

from naseview.testbed.synth.command import synth_command
from naseview.testbed.synth.photo import render_photo
from naseview.testbed.synth.rig import DEFAULT_SIZE, sample_identity, sample_rig
from naseview.testbed.synth.scene import Scene, build_scene
from naseview.testbed.synth.synthesize import random_streams, synthesize_case

__all__ = ["DEFAULT_SIZE", "Scene", "build_scene", "random_streams", "render_photo",
           "sample_identity", "sample_rig", "synth_command", "synthesize_case"]
