"""The output policy as the reporting layer uses it: :mod:`glocal_verify.runtime.files`.

Kept so that ``glocal_verify.reporting.output`` goes on naming the functions every report
writer calls; the policy itself (atomic writes, all-or-nothing folders, checks before
computing) lives, once, in :mod:`glocal_verify.runtime.files`, where the lower layers that
write files (sweeps, audit figures) reach it too.
"""

from __future__ import annotations

from glocal_verify.runtime.files import (
    OutputError,
    OutputFolder,
    check_output_dir,
    check_output_file,
    safe_component,
    same_file,
    write_bytes_atomic,
    write_text_atomic,
)

__all__ = [
    "OutputError",
    "safe_component",
    "write_text_atomic",
    "write_bytes_atomic",
    "check_output_file",
    "check_output_dir",
    "same_file",
    "OutputFolder",
]
