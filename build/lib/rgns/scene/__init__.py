"""The scene: what a slope is before any engine runs it.

In: the config's domain, geometry families, sets and random-field models, or a site's DEM section.
Out: seeded realizations (:mod:`rgns.scene.realizations`, numbered through a set's groups by
:mod:`rgns.scene.sets`): a body's vertices and material points
(:mod:`rgns.scene.geometry`, :mod:`rgns.scene.slope_generator`, :mod:`rgns.scene.site`) and each
point's friction angle from a Gaussian random field (:mod:`rgns.scene.fields`), every random draw
from its own stream (:mod:`rgns.scene.seeds`); the case every engine runs, built in memory
(:mod:`rgns.scene.build`, with its geostatic start, :mod:`rgns.scene.geostatic`). Nothing here imports an
engine, a surrogate or a file reader or writer.
"""
