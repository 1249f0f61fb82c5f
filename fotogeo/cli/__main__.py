"""``python -m fotogeo.cli``: the ``fotogeo`` command where its script is not on the PATH (the same group)."""
from . import main

if __name__ == "__main__":  # importing the module (doctest collection) runs nothing
    main(prog_name="fotogeo")
