"""``python -m thinfilm``: the same as the ``thinfilm`` console script."""

import sys

from thinfilm.cli import main

sys.exit(main())
