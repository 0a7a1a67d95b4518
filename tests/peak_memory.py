"""A child ``dynval`` run that reports its own peak resident memory, for the memory-bound tests.

``[sys.executable, "-c", PEAK_LAUNCHER, "validate", ...]`` runs ``dynval validate ...`` and writes
``VmHWM <kB>`` on standard error at exit: the child's own high-water mark (VmHWM of its address
space, reset at exec; ru_maxrss would also count the parent's pages at the fork).
"""

PEAK_LAUNCHER = ("import atexit, runpy, sys\n"
                 "def hwm():\n"
                 "    for line in open('/proc/self/status'):\n"
                 "        if line.startswith('VmHWM:'): sys.stderr.write('VmHWM ' + line.split()[1] + '\\n')\n"
                 "atexit.register(hwm)\n"
                 "sys.argv = ['dynval'] + sys.argv[1:]\n"
                 "runpy.run_module('dynval', run_name='__main__')\n")
