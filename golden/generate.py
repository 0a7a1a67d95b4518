#!/usr/bin/env python3
"""Generate the dynval golden corpus (``golden/vectors/<family>.json``).

The generator is the package ``golden/corpus_generator/`` (one builder module per
family, the shared exact arithmetic in ``_exact.py``); this script runs it and is
what ``python -m dynval.golden lint`` loads to reproduce the files. Usage::

    python golden/generate.py            # rewrite golden/vectors/*.json
    python golden/generate.py --check    # exit 1 if the files differ from a fresh run

Only the standard library and mpmath (pinned) are used; nothing here imports dynval.
"""

from __future__ import annotations

import hashlib
import importlib.util
import pathlib
import sys


def _load_package():
    # Loaded by path under a name unique to this checkout, so that two copies of the
    # corpus (the linter checks copies) never share a cached generator.
    package = pathlib.Path(__file__).resolve().parent / "corpus_generator"
    name = "corpus_generator_" + hashlib.sha1(str(package).encode()).hexdigest()[:12]
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, package / "__init__.py",
                                                  submodule_search_locations=[str(package)])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


_generator = _load_package()
globals().update({name: getattr(_generator, name) for name in _generator.__all__})
__all__ = list(_generator.__all__)

if __name__ == "__main__":
    sys.exit(main())  # noqa: F821 - bound from the package above
