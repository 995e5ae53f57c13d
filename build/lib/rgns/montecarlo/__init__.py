"""The Monte Carlo: a case's realizations in, a table of R, V and I per realization out.

:mod:`rgns.montecarlo.runs` draws each realization from its own seed, skips what a scene does not
need (a limit-equilibrium screen, :mod:`rgns.montecarlo.screening`), runs the rest in batches
by a route's simulator (end-state surrogate, GNS or the embedded MPM) and measures them
(:mod:`rgns.engines.metrics`); chunk tables are collected into one per case and route.
:mod:`rgns.montecarlo.routes` says which model runs which realizations at which mesh. Imports the scene,
the engines and the surrogates, nothing later.
"""
