"""Small text files (camera YAML, exterior orientation, ``.points``, RPC text/XML): read with one
clear error for a missing file, a folder or undecodable content."""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError, one_line


def read_text_file(path, what: str, *, hint: str = "", error=InputError, errors: str = "strict") -> str:
    """The text of ``path`` (UTF-8, a byte-order mark skipped); ``error`` naming ``what`` and the file
    when it is missing, a folder (``hint`` says what to give instead) or unreadable.

    ``errors="replace"`` keeps undecodable bytes as U+FFFD (the caller then parses what it can).
    """
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8-sig", errors=errors)
    except FileNotFoundError:
        raise error(f"{what} {str(path)!r} does not exist") from None
    except IsADirectoryError:
        raise error(f"{what} {str(path)!r} is a folder" + (f"; {hint}" if hint else "")) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(one_line(f"cannot read {what} {str(path)!r} as UTF-8 text: {exc}")) from None
