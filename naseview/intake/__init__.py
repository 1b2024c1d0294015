"""A new patient without a browser: four photos and guided landmark clicks -> a case
directory (SPEC §3) for the pipeline; no viser here.

- :mod:`~naseview.intake.photos`: photo intake (orientation, size limits, no metadata);
- :mod:`~naseview.intake.click_order`: which photo first and which landmark next;
- :mod:`~naseview.intake.guidance`: hints from a quick stage 1 (paper §3.2);
- :mod:`~naseview.intake.session`: :class:`AnnotationSession`, autosaved as
  ``annotation.json``; a photo replacement is all or nothing with its clicks;
- :mod:`~naseview.intake.annotation_file`: the ``naseview.annotation/1`` file, validated
  on resume (one line naming the file and the key);
- :mod:`~naseview.intake.patients`: the work folder, one id per patient, a fresh folder
  for each new patient.
"""
