"""``python -m meshwm.apps.cli ...``: the same as the ``meshwm`` command."""

import sys

from meshwm.apps.cli import main

sys.exit(main())
