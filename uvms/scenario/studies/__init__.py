"""Many runs of a scenario: ``sweep`` (grids of overrides), ``study`` (Monte Carlo studies: ``distributions`` of the
keys, ``sensitivity`` of the metrics, the study's ``folder``), ``tune`` (Optuna over scenario keys), all run by
``parallel`` (joblib's loky or Dask)."""
