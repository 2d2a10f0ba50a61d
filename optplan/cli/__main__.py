"""``python -m optplan.cli``: the ``optplan`` command."""

import sys

from optplan.cli.app import main

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
