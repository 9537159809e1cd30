"""Fleet-scale replay of an operator's archive on Dask (see :mod:`.run`)."""
