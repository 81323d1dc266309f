"""``python -m uvms.cli ...``: the same as the ``uvms`` console script."""

import sys

from . import main

sys.exit(main())
