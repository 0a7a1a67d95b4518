"""The one place where dynval's version and its contract's version are written.

pyproject.toml reads ``__version__`` (scikit-build-core's regex provider), CMakeLists.txt reads
both to generate ``dynval/version.hpp`` for the C++ core and its installed package, and the Python
package imports them from here. The ports state the contract version they implement; a test checks
that they claim this one.
"""

__version__ = "0.1.0"
CONTRACT_VERSION = "1.0"
