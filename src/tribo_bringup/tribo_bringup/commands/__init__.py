"""Subcommands of the tribo CLI (each module: register(subparsers))."""
