"""Where a run's work goes: local worker processes or a Dask cluster, and the ``--dask``
address."""
