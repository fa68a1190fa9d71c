"""The published evaluation as one sweep: runs, cached results, tables, figures and a report.

- :mod:`.sweep`: the plan of runs, their cache keys, computing the missing ones;
- :mod:`.tables`: the tables of spec section 10 from the runs' summaries;
- :mod:`.figures`: the figures of spec section 10 as PNG;
- :mod:`.report`: ``tables.md``, the CSVs and ``report.md``;
- :mod:`.run`: all of it in order.
"""
