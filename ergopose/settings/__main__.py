"""``python -m ergopose.settings [FILE]``: write docs/settings.md (or FILE) from the settings model;
``--check`` only says whether it is up to date (exit 1 when not)."""

from __future__ import annotations

import sys
from pathlib import Path

from ergopose.settings.generate import settings_markdown

DOCS = Path(__file__).resolve().parents[2] / "docs" / "settings.md"


def main(argv: list[str]) -> int:
    if any(a in ("-h", "--help") for a in argv):
        sys.stderr.write(__doc__ + "\n")
        return 0
    check = "--check" in argv
    args = [a for a in argv if a != "--check"]
    if any(a.startswith("-") for a in args) or len(args) > 1:
        sys.stderr.write(
            f"ergopose.settings: unknown arguments {args!r}; usage: python -m ergopose.settings [--check] [FILE]\n"
        )
        return 2
    path = Path(args[0]) if args else DOCS
    text = settings_markdown()
    if check:
        same = path.is_file() and path.read_text(encoding="utf-8") == text
        sys.stderr.write(f"{path}: {'up to date' if same else 'differs from the settings model'}\n")
        return 0 if same else 1
    path.write_text(text, encoding="utf-8")
    sys.stderr.write(f"wrote {path}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
