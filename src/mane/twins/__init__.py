"""NumPy twins of the GPU kernels and shading models, written from the equations and the published
papers (not from the GLSL), in float64: the golden values of the tests and of ``mane bench quality``.

    from mane.twins import shading, sim
    shading.kajiya_kay(T, V, L, material)         # the published equations of a GLSL model
    sim.integrate(x, prev, v, rest, w, head, dt, settings)   # one pass of the strand solver

``aux`` (the data set's ground-truth maps), ``chiang`` (Chiang 2016 fibre), ``curve`` (curve
schemes), ``grid`` (friction grid), ``oit`` (the exact transparency sort), ``raster`` (the compute
rasteriser), ``shading`` (the shading models), ``shadow`` (exact transmittance), ``sim`` (the strand
solver's passes). ``mane.reference`` is something else: the path-traced (Mitsuba 3) ground truth.
"""
