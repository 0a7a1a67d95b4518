"""
Checking a port against the golden corpus
=========================================

A port in any language proves itself through ``dynval conform``: a small program that speaks the
line protocol (see *The port protocol*) on stdin/stdout. Here the reference port of the package,
``python -m dynval.port``, is checked on one family of the corpus.
"""

import subprocess
import sys

run = subprocess.run([sys.executable, "-m", "dynval", "conform", "--families", "norms", "--",
                      sys.executable, "-m", "dynval.port", "--backend", "python"],
                     capture_output=True, text=True, check=True)
print(run.stdout)
