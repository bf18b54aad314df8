"""``python -m ariel.cli``: the same as the ``ariel`` command."""

import sys

from ariel.cli import main

sys.exit(main())
