"""``python -m drs_model.cli``: the same as the ``drs`` console script."""

import sys

from . import main

sys.exit(main())
