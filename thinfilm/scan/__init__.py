"""Parameter scans: one base scene, a few keys varied, every run on Dask, one table.

``thinfilm scan SCAN.toml`` reads a scan file (:mod:`thinfilm.scan.plan`), validates every
generated scene, runs the runs on a Dask cluster (:mod:`thinfilm.scan.execute`: local
processes by default, any cluster by address), each as ``thinfilm run`` would into its own
directory (:mod:`thinfilm.scan.task`), and writes ``scan.csv`` and ``scan.png`` from the runs'
files alone (:mod:`thinfilm.scan.table`, with the metrics of :mod:`thinfilm.scan.metrics`).
``docs/scans.md`` is the user's guide.
"""

from thinfilm.scan.plan import ScanError, ScanPlan, load_plan, parse_plan

__all__ = ["ScanError", "ScanPlan", "load_plan", "parse_plan"]
