"""Subcommands of the ``ergopose`` command line; see ergopose.cli."""
