"""Writing an output file whole: into a hidden temporary file beside it, then renamed over it in one step, so a
reader (or a run interrupted half-way) never sees a half-written file. The one home of that pattern for every
command's outputs."""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Iterator


@contextmanager
def replacing(path: str | Path, newline: str | None = None) -> Iterator[IO[str]]:
    """A text file handle whose contents replace ``path`` when the block ends without an exception (its folder is
    made first); on an exception ``path`` is left as it was and the temporary file removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        with open(tmp, "w", newline=newline) as fh:
            yield fh
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def replace_text(path: str | Path, text: str) -> Path:
    """Write ``text`` as the whole of ``path`` (see :func:`replacing`); returns the path."""
    with replacing(path) as fh:
        fh.write(text)
    return Path(path)
