"""Task graph, cache keys, archive I/O, dask execution and the saltation driver loop.

Entry points for other areas: :func:`saltstudy.workflow.paths.analysis_paths` and
:func:`saltstudy.workflow.paths.default_out_dir` (the report resolves analysis archives with
them); the CLI commands ``run-all``, ``run`` and ``status`` (cli_commands.py).
"""
