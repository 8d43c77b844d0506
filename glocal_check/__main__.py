"""``python -m glocal_check SPEC FILE``: one line per rejected certificate, then the summary;
exit 0 only when nothing is rejected and every decided verdict has a certificate (1 otherwise,
2 for a file it cannot read)."""

from __future__ import annotations

import sys

from glocal_check.check import check_files
from glocal_check.spec import CheckError


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2 or args[0].startswith("-"):
        print("usage: python -m glocal_check SPEC CERTIFICATES", file=sys.stderr)
        return 2
    try:
        out = check_files(args[0], args[1])
    except CheckError as exc:
        print(f"glocal_check: {exc}", file=sys.stderr)
        return 2
    if out.observed():
        print(out.observed())
    print(out.summary())
    return 0 if out.ok else 1


if __name__ == "__main__":
    sys.exit(main())
