"""Task suites (``offroadbench suite``), shipped as ``offroadbench.data.suites``, and the shipped baselines' score cards (``scores/``)."""
