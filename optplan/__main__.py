"""``python -m optplan``: the same as the ``optplan`` command."""

import sys

from optplan.cli import main

if __name__ == "__main__":
    sys.exit(main())
