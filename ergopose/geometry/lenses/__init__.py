"""Lens models: one per file, each with project and unproject (see base.py)."""
