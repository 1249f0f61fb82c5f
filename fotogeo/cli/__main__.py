"""``python -m fotogeo.cli``: the ``fotogeo`` command where its script is not on the PATH (the same group)."""
from . import main

main(prog_name="fotogeo")
