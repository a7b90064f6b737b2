"""Layer 7, reports: plots, animations and the output files of the fits."""
