"""What every floor of the house shares and none of them is about: the user's errors
(twin_plumbing.errors), checked numbers and their ranges (checks), the TOML files' checked fields
(fields), what the file system says of a path (paths), output places written atomically and
locked (outputs), SIGTERM as Ctrl-C (signals), the Dask cluster of `--scheduler` (cluster) and a
log's provenance (provenance).

The bottom floor: it imports none of the project's packages (pyproject.toml, [tool.importlinter]),
so pneumatics/ and everything above may use it. Nothing is imported here; import from the modules.
"""
