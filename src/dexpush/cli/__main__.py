"""``python -m dexpush.cli``: the command line."""

import sys

from dexpush.cli.main import main

sys.exit(main())
