"""The report: every stage's files in, one HTML page and its figures out.

:mod:`rgns.report.page` assembles the page, leading with what the reader must trust or distrust
(the gate's verdicts, the corrected and converged estimates); :mod:`rgns.report.plots` draws the
scene, field and learning-curve figures the pipeline's rules also use on their own.
"""
