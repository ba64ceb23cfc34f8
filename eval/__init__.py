"""Evaluation: run methods on tasks (``optimize``), compare their records (``compare``), studies.
Command line: ``python -m eval --help``; each subcommand a module of :data:`eval.__main__.SUBCOMMANDS`.
"""
