"""``python -m ergopose.settings [FILE]``: write docs/settings.md (or FILE) from the settings model;
``--check`` only says whether it is up to date (exit 1 when not)."""

from __future__ import annotations

import sys
from pathlib import Path

from ergopose.settings.generate import settings_markdown

DOCS = Path(__file__).resolve().parents[2] / "docs" / "settings.md"


def main(argv: list[str]) -> int:
    check = "--check" in argv
    args = [a for a in argv if a != "--check"]
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
