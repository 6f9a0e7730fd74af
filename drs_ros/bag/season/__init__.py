"""Many bags: the fleet on Dask and its Parquet table, ``drs-bag index``, ``drs-bag fit``
(identification) and ``drs-bag trend``."""
