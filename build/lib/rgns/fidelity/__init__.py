"""Fidelity: the Monte Carlo's cheap answers and a few accurate pairs in; the hazard at the accurate,
then the converged, mesh out.

:mod:`rgns.fidelity.multifidelity` is the control-variate estimator (means, exceedance curves, the
probability of being affected) with intervals that carry the estimated weights;
:mod:`rgns.fidelity.multilevel` extends it to nested levels; :mod:`rgns.fidelity.mesh_extrapolation`
adds the Richardson step to the converged mesh at the measured order; :mod:`rgns.fidelity.outputs`
writes one case's corrected record and figure. Imports the scene and the hazard statistics (the
zoning it corrects), nothing of the engines, surrogates or report.
"""
