"""Hazard: a Monte Carlo table of R, V and I in; the hazard out.

:mod:`rgns.hazard.statistics` turns the realizations into convergence, exceedance curves and
distances with confidence bands, the probability of being affected and the five-level zoning;
:mod:`rgns.hazard.outputs` writes them per case (JSON, CSV) with their figures
(:mod:`rgns.hazard.plots`); :mod:`rgns.hazard.site_gis` gives a site's zones as GeoJSON along its
section line and the exceedance per chainage as CSV.
"""
