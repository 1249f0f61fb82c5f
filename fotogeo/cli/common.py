"""What the sub-commands share: a console progress bar and error reporting."""
from __future__ import annotations

import functools
import sys

import click

from ..errors import Cancelled, FotogeoError


class ConsoleProgress:
    """A progress callback drawing one updating line on stderr (silent when ``quiet``)."""

    def __init__(self, quiet: bool = False, width: int = 30):
        self.quiet, self.width, self.last = quiet, width, ""

    def __call__(self, fraction: float, message: str) -> bool:
        if self.quiet:
            return True
        filled = int(round(self.width * fraction))
        line = f"\r[{'#' * filled}{'.' * (self.width - filled)}] {fraction * 100:5.1f}% {message[:50]:<50}"
        if line != self.last:
            sys.stderr.write(line)
            sys.stderr.flush()
            self.last = line
        return True

    def close(self):
        if not self.quiet and self.last:
            sys.stderr.write("\n")
            sys.stderr.flush()


def run_tool(func):
    """Decorator for command bodies: FotogeoError -> one 'Error: ...' line and exit code 2."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except Cancelled as e:
            raise click.ClickException(f"cancelled: {e}") from None
        except FotogeoError as e:
            click.echo(f"Error: {e}", err=True)
            sys.exit(2)
    return wrapper
