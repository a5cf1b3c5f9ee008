"""``python -m examples.bar ARGS``: ``thinfilm ARGS`` with ``kind = "bar"`` registered.

A kind outside the toolkit is known only to the process that registers it, so the command
line of the example registers it and hands over to the toolkit's own::

    python -m examples.bar run examples/bar/bar.toml     # writes examples/bar/bar/
    python -m examples.bar info examples/bar/bar
    python -m examples.bar plot examples/bar/bar --t 1.5 3.0
"""

import sys

from examples.bar.kind import KIND
from thinfilm import kinds
from thinfilm.cli import main

kinds.register(KIND)
sys.exit(main())
