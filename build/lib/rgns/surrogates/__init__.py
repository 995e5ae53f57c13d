"""The surrogates: MPM runs in, learned simulators out, each proven against MPM before any map uses it.

:mod:`rgns.surrogates.endstate` maps a slope at rest to its material points at rest in one U-Net
evaluation (data, training, tuning to a finer mesh, model cards); :mod:`rgns.surrogates.gns` is the
paper's graph network simulator, rolled out frame by frame, with :mod:`rgns.surrogates.gns_export`
writing GNS's own training format. :mod:`rgns.surrogates.pairing` runs a surrogate and MPM on the same
realizations, :mod:`rgns.surrogates.validation` scores the pairs (R², NRMSE, bias with bootstrap
intervals; figures in :mod:`rgns.surrogates.validation_plots`), :mod:`rgns.surrogates.gate` decides per
case whether the Monte Carlo may use the surrogate, and :mod:`rgns.surrogates.shipped` serves the
models committed under ``rgns/models``. Imports the scene and the engines, nothing later.
"""
