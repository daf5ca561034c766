"""`python -m twin_cli ...`: the `twin` command without its console script."""

import sys

from twin_cli.cli import main

sys.exit(main())
