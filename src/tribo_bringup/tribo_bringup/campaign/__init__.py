"""Campaigns: many sessions analysed on dask.distributed into one Parquet + DuckDB store.

One job per module: :mod:`.spec` (the YAML campaign spec), :mod:`.analyses` (the
one adapter to the analysis library: a task in, table rows out), :mod:`.store`
(Parquet tables, keys, atomic commits, the DuckDB views, the run lock),
:mod:`.runner` (tasks on a dask cluster, one commit per session),
:mod:`.progress` (bar, ETA, status lines), :mod:`.query` (SQL on the store,
CSV/Parquet export) and :mod:`.report` (the campaign's HTML page). No module
imports rclpy; ``tribo campaign`` (:mod:`tribo_bringup.commands.campaign`) is
the shell over them.
"""
