"""``python -m convoy_mav`` runs the command line."""

from __future__ import annotations

import sys

from convoy_mav.cli import main

sys.exit(main())
