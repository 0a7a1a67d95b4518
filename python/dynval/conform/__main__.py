"""``python -m dynval.conform [options] -- COMMAND ARGS...`` (same as ``dynval conform``)."""

from . import main

raise SystemExit(main())
