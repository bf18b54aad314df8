"""``python -m ariel.cli``: the same as the ``ariel`` command."""

import sys

from ariel.cli import main

if __name__ == "__main__":  # importing this module (a docs tool may) runs nothing
    sys.exit(main())
