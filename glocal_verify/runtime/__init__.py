"""Runtime: what the toolkit asks of the operating system, under one policy.

- :mod:`.files` -- every file written atomically, output folders all or nothing, output
  locations checked before computing (never an input, never through a symbolic link), file
  names derived safely from spec text;
- :mod:`.processes` -- stop signals (``SIGINT``, ``SIGTERM``, ``SIGHUP``) turned into one
  exception that every clean-up handles, and child processes that die with their parent;
- :mod:`.lines` -- every line on stderr written whole (text and newline in one write), and
  the stop line of a signal on a fresh line.

Layer: right above :mod:`glocal_verify.errors`; imports nothing else of the package, and every
layer above may use it.
"""
