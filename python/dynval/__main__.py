"""``python -m dynval``: the same command line as ``dynval``."""

import sys

from .cli import main

sys.exit(main())
