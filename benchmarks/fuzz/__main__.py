"""``python -m benchmarks.fuzz`` (from the repository): the full run, or a worker
(``--worker``, started by :mod:`benchmarks.fuzz.runner`)."""

import sys

from benchmarks.fuzz.report import main

if __name__ == "__main__":
    sys.exit(main())
