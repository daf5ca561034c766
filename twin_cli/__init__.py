"""The `twin` command line: the application layer above every other package (README "Layout").

twin_cli.cli.main parses the command line and runs one subcommand; each area's subcommands are a
module of their own (run_commands, log_commands, plot_command, study_commands, gap_commands) that
only reads arguments, calls the library and prints. Nothing imports twin_cli (tests/test_layers.py).
"""
