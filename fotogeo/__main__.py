"""``python -m fotogeo``: the command line, as the ``fotogeo`` script."""
from .cli import main

if __name__ == "__main__":
    main()
