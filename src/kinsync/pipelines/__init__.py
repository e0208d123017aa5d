"""Pipelines: files streamed through the algorithms.

The layer between `kinsync.io` (formats) and the command line: a pipeline reads files
with `kinsync.io`, runs the algorithm packages on the containers they give (in chunks
where files are large, on a process pool or a Dask cluster where asked), writes the
results atomically and accounts for every input record. The algorithm packages never
see a path; the CLI calls a pipeline and prints its summary.
"""
