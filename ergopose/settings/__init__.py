"""The typed model of settings.toml (pydantic): one table class per table, the one-line errors,
and the generators of the settings template and of docs/settings.md.

This package sits low in the layers (docs/architecture.md): it imports nothing of the stages, so
each stage can take its own table from here; ergopose.session turns the validated file into the
Session record and the stages' settings records.
"""
