"""Evaluation: run methods on tasks (``optimize``), compare their records (``compare``), studies.

Command line: ``python -m eval --help``. Each subcommand lives in its own module, registered in
:data:`eval.__main__.SUBCOMMANDS`.
"""
