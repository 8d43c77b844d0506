"""glocal_check: an independent checker of the certificates ``glocal-verify verify
--certificates FILE`` writes.

It reads the spec itself (:mod:`glocal_check.spec`), rebuilds the paper's matrices from the
spec's exact rationals, and re-checks each certificate in exact (``fmpq``, residues modulo a
prime, polynomials) or ball (``acb``) arithmetic with python-flint only. It imports nothing
from ``glocal_verify`` (a test parses its imports), and no check searches for anything: each
verifies the data it is given. ``docs/certificates.md`` gives the certificate of every
condition id, its mathematics and what the checker trusts.

Command line: ``python -m glocal_check SPEC FILE``.
"""

from glocal_check.check import Outcome, check_files
from glocal_check.spec import CheckError

__all__ = ["CheckError", "Outcome", "check_files"]
