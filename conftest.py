"""Makes the working tree's ergopose importable in tests (the repository root is on sys.path)."""
