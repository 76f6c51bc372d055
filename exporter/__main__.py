"""``python -m exporter`` runs the ``vworld-lod`` command line."""

import sys

from .cli import main

sys.exit(main())
