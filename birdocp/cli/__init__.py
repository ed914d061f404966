"""The command line: the parser, one module per command, and the run-folder context they share."""
