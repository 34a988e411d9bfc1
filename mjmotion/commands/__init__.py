"""One module per CLI verb: ``NAME``, ``HELP``, optional ``DESCRIPTION``, ``add_arguments``, ``run``."""
