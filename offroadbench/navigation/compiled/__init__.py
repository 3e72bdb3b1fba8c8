"""Navigation's numba kernels, each the same numbers as the numpy/scipy code it stands in for (tested to
the bit, also compiled for the x86-64 baseline): the footprint hazard's plane residuals (:mod:`.planes`),
MPPI's rollout cos/sin (:mod:`.mppi`), the mast sensor's sweep (:mod:`.sweep`) and its seen map's Gaussian
filter (:mod:`.smooth`). Each module compiles on import, so it is imported only where used and only when
numba is installed (the ``fast`` extra); this package imports none of them."""
