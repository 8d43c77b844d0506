"""``python -m glocal_verify.cli``: the same as the ``glocal-verify`` command."""

import sys

from glocal_verify.cli import entry_point

sys.exit(entry_point())
