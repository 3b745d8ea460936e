"""``python -m vistir.campaign …``: the same as the ``vistir-campaign`` command."""

import sys

from .cli import main

sys.exit(main())
