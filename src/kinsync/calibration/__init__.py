"""Mount self-calibration from survey data: boresight, lever arm and latency.

The lines of a survey (`kinsync.calibration.lines.ScanLine`: scanner-frame returns
with times, and the trajectory) are georeferenced with a candidate mount; features
seen by several lines (spheres, planar patches) must then coincide. The estimator
solves for the mount parameters with the features as nuisance parameters, reports an
honest standard deviation (errors correlated within a line) and says which parameters
the data could not determine.
"""
