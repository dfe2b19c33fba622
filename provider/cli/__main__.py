"""``python -m provider.cli``: the same as the ``shlight`` command."""
import sys

from . import main

sys.exit(main())
