"""Fleets: many records, or one long record's chunks, spread over workers.

Orchestration above the method: :mod:`.records` runs
:func:`~moli.method.identification.identify` on every record of a fleet,
:mod:`.chunk_reduction` reduces a long record's chunks to one least-squares estimate on
Dask workers, and :mod:`.backends` is where both run (this process, local processes,
Dask, any ``concurrent.futures`` executor), :mod:`.dask_workers` how Dask workers are
set up to run them at full speed.
"""

from .chunk_reduction import estimate_chunks
from .dask_workers import dask_worker_config
from .records import FleetEntry, FleetResult, identify_many

__all__ = ["FleetEntry", "FleetResult", "identify_many", "estimate_chunks", "dask_worker_config"]
