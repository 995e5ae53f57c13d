"""``python -m evidence``: rewrite (or ``--check``) every rendered passage."""

import sys

from evidence import main

sys.exit(main())
