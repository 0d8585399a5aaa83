"""How a benchmark writes its page: ``<name>.md`` and, with data, ``<name>.json`` beside it."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Callable


def write_page(out_dir: Path | str, name: str, markdown: str | Callable[[], str], data=None) -> Path:
    """Write ``out_dir/<name>.json`` when ``data`` is not None (JSON-compatible data, indented by
    one, ending in a newline), then ``out_dir/<name>.md`` (ending in one newline), both UTF-8, the
    folder made if need be; return the page's path. ``markdown`` is the page's text, or a function
    returning it, called once the data is on disk: a bench whose formatting (or plotting) fails
    after a long run still leaves its measurements."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if data is not None:
        (out_dir / f"{name}.json").write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    text = markdown() if callable(markdown) else markdown
    page = out_dir / f"{name}.md"
    page.write_text(text.rstrip("\n") + "\n", encoding="utf-8")
    return page
