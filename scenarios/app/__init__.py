"""The application: the ``geofence-testbed`` command line, batch runs and experiments.

The CLI, the batch runner (local processes or Dask) and experiments such as the
seed-work reproduction. The top layer: it may import everything below.
"""
