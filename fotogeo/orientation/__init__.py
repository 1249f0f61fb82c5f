"""Orientation on arrays: GCP adjustment with data snooping and model comparison, terrain-aware 3-D fits, RPC and
its bias compensation, interior orientation of film scans, the bundle block adjustment (problem, Jacobians,
reduced normals, Levenberg–Marquardt, robust phase, quality), simulated and rendered blocks with known truth,
ground σ from a frame's covariance."""
