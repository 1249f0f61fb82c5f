"""MkDocs hook: the API reference lists the façade's tools from ``fotogeo._TOOLS`` (name -> module under
fotogeo.tools, followed to the module that defines each), so the page follows the tools wherever they live; ``<!-- fotogeo-tools -->`` marks the spot."""
from __future__ import annotations

MARKER = "<!-- fotogeo-tools -->"


def on_page_markdown(markdown, page, config, files):
    if MARKER not in markdown:
        return markdown
    import importlib

    import fotogeo
    blocks = []
    for name, module in fotogeo._TOOLS.items():
        obj = getattr(importlib.import_module(f"fotogeo.tools.{module}"), name)  # where it is defined
        blocks.append(f"### `fotogeo.{name}`\n\n::: {obj.__module__}.{obj.__qualname__}\n    options:\n"
                      f"      show_root_heading: false\n")
    return markdown.replace(MARKER, "\n".join(blocks))
