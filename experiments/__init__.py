"""Study TOMLs, shipped as ``offroadbench.data.experiments`` (``results/`` stays in the repository)."""
