"""Generic input and output that every layer may use: atomic file writes and the one JSON
converter (:mod:`~tandem_env.io.files`), ``key=value`` command-line options
(:mod:`~tandem_env.io.keyvalue`) and the progress bar on stderr
(:mod:`~tandem_env.io.progress_bar`). Nothing here imports another part of the project."""
