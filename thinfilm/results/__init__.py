"""Results files: written step by step (:mod:`~thinfilm.results.writer`), read back from the
file alone (:mod:`~thinfilm.results.reader`), summarized by ``thinfilm info``
(:mod:`~thinfilm.results.info`). The layout is described in ``docs/results.md``."""

from thinfilm.results.reader import Results, ResultsError, finished_steps, open_results
from thinfilm.results.writer import ResultsWriter, ResumeError, write_summary

__all__ = ["Results", "ResultsError", "finished_steps", "open_results", "ResultsWriter", "ResumeError",
           "write_summary"]
