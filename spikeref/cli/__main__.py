"""``python -m spikeref.cli``: the ``spikeref`` command."""

from __future__ import annotations

import sys

from spikeref.cli import main

__all__: list[str] = []

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
