"""Applications behind the CLI commands: each takes parsed arguments and does the work."""
