"""The one rich console for all output; progress bars are silenced with ``NLOS_QUIET=1`` or ``CI=true``."""

from __future__ import annotations

import os

from rich.console import Console

console = Console(highlight=False)
QUIET = os.environ.get("NLOS_QUIET", "") not in ("", "0") or os.environ.get("CI", "").lower() == "true"
