"""The toolkit's version, read by the package root (``glocal_verify.__version__``), the command
line's ``--version`` and the generator field of every exported file.

Layer: the lowest, beside :mod:`glocal_verify.errors`; imports nothing.
"""

__all__ = ["__version__"]

#: the release (pyproject.toml's ``version``)
__version__ = "0.1.0"
