"""Certificates of verdicts: for every decided verdict of a ``verify`` run, the data that
proves it and that the independent checker ``glocal_check`` re-checks without searching
(``docs/certificates.md``).

- :mod:`.document` -- the file: what it assumes (the spec's exact rationals) and one entry per
  decided verdict (:func:`certificate_document`, :func:`certificate_json`);
- :mod:`.facts` -- the combinatorial verdicts' facts;
- :mod:`.global_certificates` -- unobservable subspaces, ZDAs and touches, eigenstructure,
  the central observer;
- :mod:`.local_certificates` -- the local observers' pencils and UIOs;
- :mod:`.encode`, :mod:`.kernels` -- numbers and vectors as a certificate writes them,
  residues modulo a prime, exact kernel vectors.

Layer: above :mod:`glocal_verify.conditions` (it reads a report's verdicts and recomputes
what a witness lacks from the ``System`` with the exact tools of :mod:`glocal_verify.numerics`,
:mod:`glocal_verify.analysis` and :mod:`glocal_verify.observers`); below ``answer``.
"""

from glocal_verify.certificates.document import CERTIFICATE_FORMAT, CERTIFICATE_VERSION, certificate_document, certificate_json

__all__ = ["CERTIFICATE_FORMAT", "CERTIFICATE_VERSION", "certificate_document", "certificate_json"]
